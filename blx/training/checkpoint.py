"""Atomic checkpoints of a training-state pytree.

A checkpoint is one file, ``checkpoint.npz``: every leaf under its pytree path (``.params.policy...``)
plus the JSON metadata, written to a temporary file, synced, and moved into place with one
``os.replace`` (atomic on POSIX). A crash at any point of a write leaves either the previous
checkpoint or the new one, never a mix; the temporary file it leaves is removed by the next save.
Restoring into another structure, or from a damaged file, raises a ``CheckpointError`` naming the
file and what does not match.

A checkpoint may be written *compact* (``save(..., compact=True)``, ``rewrite(..., compact=True)``),
for carrying it between machines: lossless, every numeric array's bytes regrouped by their place in
an element (all first bytes, then all second bytes, ...) and deflated. A float's sign-and-exponent
bytes vary little across an array, so they deflate well once side by side; trained float32
parameters shrink by about 18 % this way, against 9 % deflated as they are
(benchmarks/RESULTS.md, session 29). Reading needs nothing to be said: ``restore``, ``read_arrays``
and ``rewrite`` read either form, and a run resumed from a compact checkpoint writes its next one
plain.

Checkpoints of blx before this format (``state.npz`` + ``meta.json``) are still read.
"""

from __future__ import annotations

import glob
import json
import os
import zipfile
import zlib
from typing import Any, Callable

import jax
import numpy as np

__all__ = ["CheckpointError", "save", "rewrite", "restore", "exists", "read_meta", "read_arrays",
           "path"]

FILE = "checkpoint.npz"
_META_KEY = "__meta__"
_LAYOUT_KEY = "__compact__"  # compact checkpoints: {key: [dtype, shape]} of every regrouped array
_LEGACY_DATA, _LEGACY_META = "state.npz", "meta.json"


class CheckpointError(ValueError):
  """A checkpoint that cannot be read into this run: damaged, or of another structure."""


def path(directory: str) -> str:
  return os.path.join(directory, FILE)


def _legacy(directory: str) -> bool:
  return (os.path.exists(os.path.join(directory, _LEGACY_META))
          and os.path.exists(os.path.join(directory, _LEGACY_DATA)))


def exists(directory: str) -> bool:
  return os.path.exists(path(directory)) or _legacy(directory)


def _clean_temporaries(directory: str) -> None:
  for stale in glob.glob(os.path.join(directory, f".{FILE}.*.tmp")):
    try:
      os.remove(stale)
    except OSError:
      pass


def _keyed_leaves(tree: Any) -> list[tuple[str, Any]]:
  return [(jax.tree_util.keystr(p), x) for p, x in jax.tree_util.tree_flatten_with_path(tree)[0]]


def save(directory: str, tree: Any, meta: dict, *, compact: bool = False) -> None:
  """Writes ``tree``'s leaves (keyed by pytree path) and ``meta`` (JSON-able) as one file,
  atomically; ``compact``: regrouped and deflated (see the module's docstring), smaller and slower
  to write."""
  arrays = {key: np.asarray(x) for key, x in _keyed_leaves(jax.device_get(tree))}
  if (_META_KEY in arrays or _LAYOUT_KEY in arrays
      or len(arrays) != len(jax.tree.leaves(tree))):
    raise ValueError("checkpoint.save: the state's pytree paths are not unique")
  _write(directory, arrays, meta, compact=compact)


def rewrite(directory: str, *, keep: Callable[[str], bool] = lambda key: True,
            meta_update: dict | None = None, compact: bool = False) -> None:
  """Writes the checkpoint in ``directory`` again, atomically, with only the arrays whose pytree
  path (``.params.policy...``) ``keep`` accepts, its metadata updated by ``meta_update``, and
  compact or plain as ``compact`` says (whatever it was). The checkpoint before it stays whole
  until the new one is in place."""
  if not os.path.exists(path(directory)) and _legacy(directory):
    raise CheckpointError(f"checkpoint in {directory} is of the old two-file format "
                          f"({_LEGACY_DATA} + {_LEGACY_META}), which keys its arrays by position; "
                          "resume the run once to write it in the current format")
  arrays, meta = _open(directory)  # a missing checkpoint: "no checkpoint at ..."
  _write(directory, {k: v for k, v in arrays.items() if keep(k)}, {**meta, **(meta_update or {})},
         compact=compact)


def _regrouped(x: np.ndarray) -> np.ndarray:
  """``x``'s bytes as ``uint8[itemsize, size]``: row b holds byte b of every element."""
  return np.ascontiguousarray(x.reshape(-1).view(np.uint8).reshape(-1, x.dtype.itemsize).T)


def _ungrouped(rows: np.ndarray, dtype: str, shape: list[int]) -> np.ndarray:
  """The inverse of ``_regrouped``: the array of ``dtype`` and ``shape`` made of ``rows``' bytes."""
  return np.ascontiguousarray(rows.T).view(np.dtype(dtype)).reshape(shape)


def _write(directory: str, arrays: dict[str, np.ndarray], meta: dict, *,
           compact: bool = False) -> None:
  os.makedirs(directory, exist_ok=True)
  _clean_temporaries(directory)
  arrays = dict(arrays)
  if compact:
    layout = {}
    for key, x in arrays.items():
      if x.dtype.kind in "fiuc" and x.dtype.itemsize > 1:  # numbers of several bytes
        layout[key] = [x.dtype.str, list(x.shape)]
        arrays[key] = _regrouped(x)
    arrays[_LAYOUT_KEY] = np.frombuffer(json.dumps(layout, sort_keys=True).encode(), np.uint8)
  arrays[_META_KEY] = np.frombuffer(json.dumps(meta, sort_keys=True).encode(), np.uint8)
  tmp = os.path.join(directory, f".{FILE}.{os.getpid()}.tmp")
  with open(tmp, "wb") as f:
    (np.savez_compressed if compact else np.savez)(f, **arrays)
    f.flush()
    os.fsync(f.fileno())
  os.replace(tmp, path(directory))
  try:  # make the rename itself durable
    fd = os.open(directory, os.O_RDONLY)
    try:
      os.fsync(fd)
    finally:
      os.close(fd)
  except OSError:
    pass


# What reading a damaged (truncated, overwritten, foreign) checkpoint file raises.
_UNREADABLE = (zipfile.BadZipFile, zlib.error, OSError, EOFError, KeyError, ValueError)


def _damaged(file: str, e: Exception) -> CheckpointError:
  return CheckpointError(f"checkpoint {file} is damaged and cannot be read ({e}); delete it to "
                         "start over")


def _open(directory: str) -> tuple[dict[str, np.ndarray], dict]:
  """All arrays and the metadata of the checkpoint in ``directory``."""
  if not os.path.exists(path(directory)) and _legacy(directory):
    return _open_legacy(directory)
  file = path(directory)
  try:
    with np.load(file) as data:
      arrays = {k: data[k] for k in data.files}
    meta = json.loads(arrays.pop(_META_KEY).tobytes().decode())
    if _LAYOUT_KEY in arrays:
      layout = json.loads(arrays.pop(_LAYOUT_KEY).tobytes().decode())
      for key, (dtype, shape) in layout.items():
        arrays[key] = _ungrouped(arrays[key], dtype, shape)
  except FileNotFoundError:
    raise CheckpointError(f"no checkpoint at {file}") from None
  except _UNREADABLE as e:
    raise _damaged(file, e) from None
  return arrays, meta


def _open_legacy(directory: str) -> tuple[dict[str, np.ndarray], dict]:
  data_file = os.path.join(directory, _LEGACY_DATA)
  meta_file = os.path.join(directory, _LEGACY_META)
  try:
    with open(meta_file) as f:
      meta = json.load(f)
    with np.load(data_file) as data:
      arrays = {k: data[k] for k in data.files}
  except (zipfile.BadZipFile, OSError, EOFError, ValueError) as e:
    raise CheckpointError(f"checkpoint {data_file} / {meta_file} is damaged and cannot be read "
                          f"({e})") from None
  if meta.get("num_leaves") != len(arrays):
    raise CheckpointError(f"checkpoint {data_file} holds {len(arrays)} arrays but {meta_file} "
                          f"says {meta.get('num_leaves')}: the two files are from different saves")
  return arrays, meta


def read_meta(directory: str) -> dict:
  """The checkpoint's metadata, read without loading its arrays."""
  file = path(directory)
  if not os.path.exists(file):
    return _open(directory)[1]  # legacy, or missing: _open says which
  try:
    with np.load(file) as data:
      return json.loads(data[_META_KEY].tobytes().decode())
  except _UNREADABLE as e:
    raise _damaged(file, e) from None


def read_arrays(directory: str) -> tuple[dict[str, np.ndarray], dict]:
  """Every array of the checkpoint in ``directory``, keyed by pytree path, and its metadata, read
  without a structure to restore into (plain or compact alike)."""
  return _open(directory)


def restore(directory: str, like: Any) -> tuple[Any, dict]:
  """Loads a checkpoint into the structure of ``like`` (a pytree of arrays or shape structs).

  Reading never deletes anything: a run may be evaluated while it trains and writes."""
  arrays, meta = _open(directory)
  file = path(directory)
  keyed, treedef = jax.tree_util.tree_flatten_with_path(like)
  keys = [jax.tree_util.keystr(p) for p, _ in keyed]
  if not os.path.exists(file):  # legacy: positional leaves
    file = os.path.join(directory, _LEGACY_DATA)
    if len(arrays) != len(keys):
      raise CheckpointError(f"checkpoint {file} holds {len(arrays)} arrays but this run's state "
                            f"has {len(keys)}: it was written by a different env, objective or "
                            "config")
    arrays = {key: arrays[f"leaf_{i:05d}"] for i, key in enumerate(keys)}
  missing = [k for k in keys if k not in arrays]
  extra = [k for k in arrays if k not in set(keys)]
  if missing or extra:
    raise CheckpointError(
        f"checkpoint {file} has another structure than this run's state (written by a different "
        f"env, objective or config): missing {missing[:3]}{' ...' if len(missing) > 3 else ''}, "
        f"unexpected {extra[:3]}{' ...' if len(extra) > 3 else ''}")
  leaves = []
  for key, (_, ref) in zip(keys, keyed):
    x = arrays[key]
    if x.shape != tuple(ref.shape) or x.dtype != ref.dtype:
      raise CheckpointError(f"checkpoint {file}: {key} is {x.dtype}{list(x.shape)} but this run "
                            f"expects {ref.dtype}{list(ref.shape)}; it was written by a different "
                            "env, objective or config")
    leaves.append(jax.numpy.asarray(x))
  return jax.tree.unflatten(treedef, leaves), meta
