"""benchmarks/carry.py: a run tree packed into size-limited parts and unpacked again, without the
envs' state unless asked; refusals of parts that are not one whole pack and of a pack that would
land on existing files."""

import io
import os
import tarfile
from typing import NamedTuple

import numpy as np
import pytest

from blx.training import checkpoint
from tests.experiments import load_benchmark

carry = load_benchmark("carry")

PART_MB = 0.01  # 10 kB parts, so that the tree below needs several


class _State(NamedTuple):  # pytree paths .env_state and .params, as a TrainState's
  env_state: np.ndarray
  params: np.ndarray


def _tree(root) -> str:
  """A sweep's ``--out`` holding one point: config, metrics and a checkpoint whose env state
  (80 kB) is most of it."""
  run = root / "src" / "mimax" / "objective=diayn"
  os.makedirs(run)
  (run / "config.json").write_text('{"objective": "diayn"}')
  (run / "metrics.csv").write_text("seed,env_steps\n0,5\n")
  state = _State(env_state=np.arange(20_000, dtype=np.float32),
                 params=np.linspace(-1, 1, 500, dtype=np.float32))
  checkpoint.save(str(run / "checkpoint"), state, {"env_state": True, "history": []})
  return str(root / "src")


def _arrays(run_dir) -> dict:
  with np.load(os.path.join(run_dir, "checkpoint", checkpoint.FILE)) as f:
    return {k: f[k] for k in f.files if k != "__meta__"}


def test_a_pack_unpacks_to_the_tree_without_the_env_state_in_parts_within_the_limit(tmp_path):
  src = _tree(tmp_path)
  parts = carry.pack(src, str(tmp_path / "out"), "hc", part_mb=PART_MB)
  sizes = [os.path.getsize(p) for p in parts]
  assert len(parts) >= 2 and max(sizes) <= PART_MB * carry.MB
  assert [os.path.basename(p) for p in parts][:2] == ["hc.tar.part_000", "hc.tar.part_001"]
  # Without the env state, the pack is far smaller than the 80 kB state alone.
  assert sum(sizes) < 40_000

  top = carry.unpack(list(reversed(parts)), str(tmp_path / "dest"))  # any order of the parts
  assert top == ["mimax"]
  run, old = tmp_path / "dest" / "mimax" / "objective=diayn", os.path.join(src, "mimax",
                                                                           "objective=diayn")
  assert (run / "config.json").read_text() == '{"objective": "diayn"}'
  assert (run / "metrics.csv").read_text() == "seed,env_steps\n0,5\n"
  arrays = _arrays(str(run))
  assert list(arrays) == [".params"]
  np.testing.assert_array_equal(arrays[".params"], np.linspace(-1, 1, 500, dtype=np.float32))
  assert checkpoint.read_meta(str(run / "checkpoint"))["env_state"] is False
  # The packed tree is left as it was, and the staging folder is gone.
  assert sorted(_arrays(old)) == [".env_state", ".params"]
  assert os.listdir(tmp_path / "dest") == ["mimax"]


def test_keep_env_state_carries_the_whole_checkpoint(tmp_path):
  parts = carry.pack(_tree(tmp_path), str(tmp_path / "out"), "full", part_mb=PART_MB,
                     keep_env_state=True)
  carry.unpack(parts, str(tmp_path / "dest"))
  arrays = _arrays(str(tmp_path / "dest" / "mimax" / "objective=diayn"))
  np.testing.assert_array_equal(arrays[".env_state"], np.arange(20_000, dtype=np.float32))


def test_parts_that_are_not_one_whole_pack_are_refused(tmp_path):
  src = _tree(tmp_path)
  parts = carry.pack(src, str(tmp_path / "out"), "a", part_mb=PART_MB)
  others = carry.pack(src, str(tmp_path / "out"), "b", part_mb=PART_MB)
  dest = str(tmp_path / "dest")
  with pytest.raises(carry.CarryError, match=f"part 001 of {len(parts)} is missing"):
    carry.unpack(parts[:1] + parts[2:], dest)
  with pytest.raises(carry.CarryError, match="parts of 2 packs"):
    carry.unpack(parts + others, dest)
  with pytest.raises(carry.CarryError, match="is not a part"):
    carry.unpack([str(tmp_path / "out" / "a.tar")], dest)
  # A stream that ends between two members, as one whose last parts were lost ends: no gap in
  # the parts' numbers shows it, and tar reads it as a whole archive. The pack's list of files is
  # what is missing.
  stream = b"".join(open(p, "rb").read() for p in parts)
  cut = stream.index(carry.MANIFEST.encode())  # where the list's header starts
  assert cut % 512 == 0
  short = tmp_path / "short"
  os.makedirs(short)
  (short / "c.tar.part_000").write_bytes(stream[:cut])
  with pytest.raises(carry.CarryError, match="not a whole pack.*last part"):
    carry.unpack([str(short / "c.tar.part_000")], dest)
  with open(parts[0], "r+b") as f:  # a part cut short in transfer, inside a file's data
    f.truncate(1_000)
  with pytest.raises(carry.CarryError, match="not a whole pack"):
    carry.unpack(parts, dest)
  assert os.listdir(dest) == []  # nothing of the broken packs stays


def test_a_pack_is_never_extracted_over_existing_files(tmp_path):
  src = _tree(tmp_path)
  parts = carry.pack(src, str(tmp_path / "out"), "a", part_mb=PART_MB)
  dest = tmp_path / "dest"
  carry.unpack(parts, str(dest))
  run = dest / "mimax" / "objective=diayn"
  (run / "config.json").write_text("mine")
  os.remove(run / "metrics.csv")
  with pytest.raises(carry.CarryError, match=r"exists \(2 of the pack's 3 files"):
    carry.unpack(parts, str(dest))
  assert (run / "config.json").read_text() == "mine" and not (run / "metrics.csv").exists()


def test_pack_refuses_an_out_dir_inside_the_tree_and_parts_already_there(tmp_path):
  src = _tree(tmp_path)
  with pytest.raises(carry.CarryError, match="lies inside"):
    carry.pack(src, os.path.join(src, "parts"), "a")
  carry.pack(src, str(tmp_path / "out"), "a", part_mb=PART_MB)
  with pytest.raises(carry.CarryError, match="already holds parts of 'a'"):
    carry.pack(src, str(tmp_path / "out"), "a", part_mb=PART_MB)


def test_the_command_names_what_is_wrong(tmp_path, capsys):
  with pytest.raises(SystemExit) as e:
    carry.main(["unpack", str(tmp_path / "x.tar.part_001"), "--into", str(tmp_path / "d")])
  assert e.value.code == 2
  assert "part 000 of 2 is missing" in capsys.readouterr().err


@pytest.mark.skipif(not hasattr(tarfile, "data_filter"), reason="tar filters: Python >= 3.11.4")
def test_an_entry_that_would_land_outside_the_destination_is_refused(tmp_path):
  out = tmp_path / "out"
  os.makedirs(out)
  payload = b"x"
  with tarfile.open(out / "evil.tar.part_000", "w") as tar:
    info = tarfile.TarInfo("../outside.txt")
    info.size = len(payload)
    tar.addfile(info, io.BytesIO(payload))
  with pytest.raises(carry.CarryError, match="would land outside --into"):
    carry.unpack([str(out / "evil.tar.part_000")], str(tmp_path / "dest"))
  assert not (tmp_path / "outside.txt").exists() and os.listdir(tmp_path / "dest") == []


def test_send_moves_the_parts_a_call_can_bring_back_until_none_are_left(tmp_path):
  stage = tmp_path / "stage"
  parts = carry.pack(_tree(tmp_path), str(stage), "hc", part_mb=PART_MB, keep_env_state=True)
  assert len(parts) >= 5
  part_mib = PART_MB * carry.MB / carry.MIB
  received = []
  for call in range(len(parts)):
    out = tmp_path / f"out{call}"
    os.makedirs(out)
    # The call's own output counts towards its limit: beside this log, one part fits, not two.
    (out / "train.log").write_bytes(b"x" * int(0.6 * PART_MB * carry.MB))
    moved, left = carry.send(str(stage), str(out), call_mib=2.5 * part_mib, call_files=8)
    # Parts leave the stage in stream order.
    assert [os.path.basename(p) for p in moved] == [
        os.path.basename(p) for p in parts[len(received):len(received) + len(moved)]]
    sent = sum(os.path.getsize(f) for f in out.iterdir())
    assert sent <= 2.5 * part_mib * carry.MIB
    if left:  # as many as fit: one whole part, and the next would not
      assert len(moved) == 1
      assert sent + os.path.getsize(left[0]) > 2.5 * part_mib * carry.MIB
    received += moved
    if not left:
      break
  assert os.listdir(stage) == []
  assert carry.unpack(received, str(tmp_path / "dest")) == ["mimax"]
  # The file count binds too: one slot left beside seven files takes one part.
  stage2 = tmp_path / "stage2"
  carry.pack(_tree(tmp_path / "again"), str(stage2), "hc", part_mb=PART_MB)
  full = tmp_path / "full"
  os.makedirs(full)
  for i in range(7):
    (full / f"log{i}").write_bytes(b"")
  moved, left = carry.send(str(stage2), str(full))
  assert len(moved) == 1 and left


def test_send_names_what_is_wrong(tmp_path, capsys):
  with pytest.raises(carry.CarryError, match="no parts"):
    carry.send(str(tmp_path), str(tmp_path / "out"))
  stage = tmp_path / "stage"
  carry.pack(_tree(tmp_path), str(stage), "hc", part_mb=PART_MB)
  with pytest.raises(carry.CarryError,
                     match=r"does not fit beside the 0 files .* smaller --part-mb"):
    carry.send(str(stage), str(tmp_path / "out"), call_mib=0.001)
  with pytest.raises(SystemExit) as e:
    carry.main(["send", str(tmp_path / "nowhere"), str(tmp_path / "out")])
  assert e.value.code == 2 and "is not a directory" in capsys.readouterr().err
  carry.main(["send", str(stage), str(tmp_path / "out")])
  assert "none left" in capsys.readouterr().out
