"""Checkpoints: one atomic file keyed by pytree path; a crash at any point of a write leaves the old
or the new checkpoint whole; damaged or foreign checkpoints are named errors."""

from __future__ import annotations

import glob
import json
import os
import zlib

import jax.numpy as jnp
import numpy as np
import pytest

from blx.training import checkpoint
from blx.training.checkpoint import CheckpointError

OLD = {"policy": {"w": np.arange(3.0, dtype=np.float32)}, "step": np.int32(1)}
NEW = {"policy": {"w": np.arange(3.0, dtype=np.float32) + 10}, "step": np.int32(2)}


def _temporaries(directory):
  return glob.glob(os.path.join(directory, ".*.tmp"))


def _restored(directory):
  tree, meta = checkpoint.restore(directory, OLD)
  return float(tree["policy"]["w"][0]), int(tree["step"]), meta["chunk"]


def test_round_trip_keeps_values_and_metadata(tmp_path):
  d = str(tmp_path)
  checkpoint.save(d, NEW, {"chunk": 2, "history": [{"a": 1.0}]})
  tree, meta = checkpoint.restore(d, OLD)
  np.testing.assert_array_equal(tree["policy"]["w"], NEW["policy"]["w"])
  assert meta == {"chunk": 2, "history": [{"a": 1.0}]}
  assert os.listdir(d) == [checkpoint.FILE]   # one file, nothing else


class Crash(Exception):
  pass


def _crash_writes(monkeypatch, crash_at):
  """The next checkpoint write dies ``crash_at``: while writing the file, before or after the
  rename that puts it in place."""
  real_savez, real_replace = np.savez, os.replace

  def savez(f, **arrays):
    if crash_at == "writing":   # half the file is on disk when the process dies
      f.write(b"PK\x03\x04 partial")
      raise Crash
    real_savez(f, **arrays)

  def replace(src, dst):
    if crash_at == "before_rename":
      raise Crash
    real_replace(src, dst)
    if crash_at == "after_rename":
      raise Crash

  monkeypatch.setattr(checkpoint.np, "savez", savez)
  monkeypatch.setattr(checkpoint.os, "replace", replace)


@pytest.mark.parametrize("crash_at", ["writing", "before_rename", "after_rename"])
def test_a_crash_anywhere_in_a_write_leaves_one_whole_checkpoint(tmp_path, monkeypatch, crash_at):
  d = str(tmp_path)
  checkpoint.save(d, OLD, {"chunk": 1})
  _crash_writes(monkeypatch, crash_at)
  with pytest.raises(Crash):
    checkpoint.save(d, NEW, {"chunk": 2})
  monkeypatch.undo()
  expected = (10.0, 2, 2) if crash_at == "after_rename" else (0.0, 1, 1)
  assert _restored(d) == expected              # old or new, never a mix
  checkpoint.save(d, NEW, {"chunk": 2})        # the next save removes the dead writer's temporary
  assert _restored(d) == (10.0, 2, 2) and not _temporaries(d)


@pytest.mark.parametrize("crash_at", ["writing", "before_rename"])
def test_a_crash_in_a_rewrite_leaves_the_whole_checkpoint(tmp_path, monkeypatch, crash_at):
  d = str(tmp_path)
  whole = {**OLD, "extra": np.ones(2, np.float32)}
  checkpoint.save(d, whole, {"chunk": 1})
  drop_extra = dict(keep=lambda key: "extra" not in key, meta_update={"light": True})
  _crash_writes(monkeypatch, crash_at)
  with pytest.raises(Crash):
    checkpoint.rewrite(d, **drop_extra)
  monkeypatch.undo()
  tree, meta = checkpoint.restore(d, whole)    # as it was, extra array and all
  np.testing.assert_array_equal(tree["extra"], whole["extra"])
  assert meta == {"chunk": 1}
  checkpoint.rewrite(d, **drop_extra)
  assert _restored(d) == (0.0, 1, 1) and not _temporaries(d)
  assert checkpoint.read_meta(d) == {"chunk": 1, "light": True}
  with pytest.raises(CheckpointError, match="unexpected|missing"):
    checkpoint.restore(d, whole)               # the extra array is gone


def test_damaged_and_foreign_checkpoints_are_named_errors(tmp_path):
  d = str(tmp_path)
  checkpoint.save(d, OLD, {"chunk": 1})
  other = {"policy": {"w": np.zeros(3, np.float32), "b": np.zeros(1, np.float32)},
           "step": np.int32(0)}
  with pytest.raises(CheckpointError, match=r"missing \[\"\['policy'\]\['b'\]\"\]"):
    checkpoint.restore(d, other)
  wrong_shape = {"policy": {"w": jnp.zeros(4, jnp.float32)}, "step": np.int32(0)}
  with pytest.raises(CheckpointError, match=r"\['policy'\]\['w'\] is float32\[3\] but this run "
                                            r"expects float32\[4\]"):
    checkpoint.restore(d, wrong_shape)
  with open(checkpoint.path(d), "r+b") as f:   # truncated, e.g. a full disk
    f.truncate(100)
  with pytest.raises(CheckpointError, match=r"checkpoint .*checkpoint.npz is damaged"):
    checkpoint.restore(d, OLD)


def test_checkpoints_of_the_two_file_format_are_still_read(tmp_path):
  d = str(tmp_path)
  np.savez(os.path.join(d, "state.npz"), leaf_00000=OLD["policy"]["w"], leaf_00001=OLD["step"])
  with open(os.path.join(d, "meta.json"), "w") as f:
    json.dump({"chunk": 1, "num_leaves": 2}, f)
  assert checkpoint.exists(d) and _restored(d) == (0.0, 1, 1)
  with pytest.raises(CheckpointError, match="old two-file format"):   # keyed by position only
    checkpoint.rewrite(d, keep=lambda key: True, meta_update={})
  with open(os.path.join(d, "meta.json"), "w") as f:   # data and metadata from different saves
    json.dump({"chunk": 2, "num_leaves": 3}, f)
  with pytest.raises(CheckpointError, match="from different saves"):
    checkpoint.restore(d, OLD)


# Every kind of leaf a TrainState holds, and the corners of the byte regrouping: a 0-d array, an
# empty one, one-byte and complex dtypes.
_MIXED = {"params": np.random.default_rng(0).normal(0, 0.1, (256, 64)).astype(np.float32),
          "mu": np.random.default_rng(1).normal(0, 1e-4, 300).astype(np.float32),
          "count": np.int32(7), "key": np.array([3, 4294967295], np.uint32),
          "steps": np.int64(2**40), "done": np.array([True, False]),
          "half": np.linspace(-2, 2, 9, dtype=np.float16),
          "z": np.array([1 + 2j, -3j], np.complex64), "empty": np.zeros((0, 5), np.float32)}


def _key(name: str) -> str:
  return f"['{name}']"   # a top-level dict entry's pytree path, as checkpoints key arrays


def test_a_compact_checkpoint_holds_exactly_the_same_arrays_in_fewer_bytes(tmp_path):
  plain, compact = str(tmp_path / "plain"), str(tmp_path / "compact")
  checkpoint.save(plain, _MIXED, {"chunk": 3})
  checkpoint.save(compact, _MIXED, {"chunk": 3}, compact=True)
  for d in (plain, compact):
    arrays, meta = checkpoint.read_arrays(d)
    assert meta == {"chunk": 3} and sorted(arrays) == sorted(_key(k) for k in _MIXED)
    for key, x in _MIXED.items():   # bit for bit, dtype and shape included
      got = arrays[_key(key)]
      assert got.dtype == x.dtype and got.shape == x.shape and got.tobytes() == x.tobytes(), key
    tree, _ = checkpoint.restore(d, _MIXED)   # into a run's structure (as jax arrays)
    np.testing.assert_array_equal(tree["params"], _MIXED["params"])
  # The float parameters' sign-and-exponent bytes deflate once side by side; the plain file is
  # uncompressed. Regrouping alone is what beats deflating the array as it is:
  assert os.path.getsize(checkpoint.path(compact)) < 0.9 * os.path.getsize(checkpoint.path(plain))
  rows = checkpoint._regrouped(_MIXED["params"])
  assert rows.shape == (4, 256 * 64) and len(zlib.compress(rows.tobytes())) < 0.95 * len(
      zlib.compress(_MIXED["params"].tobytes()))


def test_a_rewrite_makes_a_checkpoint_compact_or_plain_and_keeps_its_arrays(tmp_path):
  d, kept = str(tmp_path), [k for k in _MIXED if k != "mu"]
  checkpoint.save(d, _MIXED, {"chunk": 1}, compact=True)
  checkpoint.rewrite(d, keep=lambda key: key != _key("mu"), meta_update={"light": True})  # plain
  with np.load(checkpoint.path(d)) as f:   # stored as they are: readable without blx
    assert f[_key("params")].tobytes() == _MIXED["params"].tobytes()
    assert _key("mu") not in f.files and "__compact__" not in f.files
  checkpoint.rewrite(d, compact=True)
  arrays, meta = checkpoint.read_arrays(d)
  assert meta == {"chunk": 1, "light": True} and sorted(arrays) == sorted(map(_key, kept))
  assert all(arrays[_key(k)].tobytes() == _MIXED[k].tobytes() for k in kept)
  with np.load(checkpoint.path(d)) as f:   # regrouped on disk
    assert f[_key("params")].shape == (4, 256 * 64)


def test_a_compact_checkpoint_whose_layout_is_damaged_is_a_named_error(tmp_path):
  d = str(tmp_path)
  checkpoint.save(d, _MIXED, {"chunk": 1}, compact=True)
  with np.load(checkpoint.path(d)) as f:
    arrays = {k: f[k] for k in f.files}
  layout = json.loads(arrays["__compact__"].tobytes())
  layout[_key("params")] = ["<f4", [256, 65]]   # more elements than the bytes hold
  arrays["__compact__"] = np.frombuffer(json.dumps(layout).encode(), np.uint8)
  np.savez_compressed(checkpoint.path(d), **arrays)
  with pytest.raises(CheckpointError, match=r"checkpoint .*checkpoint.npz is damaged"):
    checkpoint.restore(d, _MIXED)
