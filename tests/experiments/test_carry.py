"""benchmarks/carry.py: a run tree packed into size-limited parts and unpacked again, without the
envs' state unless asked; refusals of parts that are not one whole pack and of a pack that would
land on existing files."""

import io
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tarfile
import time
import zipfile
from typing import NamedTuple

import numpy as np
import pytest

from blx import training
from blx.training import checkpoint
from tests.experiments import load_benchmark

carry = load_benchmark("carry")

PART_MB = 0.01  # 10 kB parts, so that the tree below needs several
# The envs' state of the tree below: 80 kB of floats that deflate little, as a simulator's do.
ENV_STATE = np.random.default_rng(0).normal(0, 1, 20_000).astype(np.float32)


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
  state = _State(env_state=ENV_STATE,
                 params=np.linspace(-1, 1, 500, dtype=np.float32))
  checkpoint.save(str(run / "checkpoint"), state, {"env_state": True, "history": []})
  return str(root / "src")


def _arrays(run_dir) -> dict:
  return checkpoint.read_arrays(os.path.join(run_dir, "checkpoint"))[0]


def _compact(run_dir) -> bool:
  """Whether the run's checkpoint is written compact (its arrays regrouped on disk)."""
  with np.load(os.path.join(run_dir, "checkpoint", checkpoint.FILE)) as f:
    return "__compact__" in f.files


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
  assert _compact(str(run))
  # The packed tree is left as it was, and the staging folder is gone.
  assert sorted(_arrays(old)) == [".env_state", ".params"] and not _compact(old)
  assert os.listdir(tmp_path / "dest") == ["mimax"]


def test_keep_env_state_carries_the_whole_checkpoint(tmp_path):
  parts = carry.pack(_tree(tmp_path), str(tmp_path / "out"), "full", part_mb=PART_MB,
                     keep_env_state=True)
  carry.unpack(parts, str(tmp_path / "dest"))
  run = str(tmp_path / "dest" / "mimax" / "objective=diayn")
  arrays = _arrays(run)
  assert arrays[".env_state"].tobytes() == ENV_STATE.tobytes()
  assert _compact(run)


def test_a_packs_checkpoints_are_compact_the_same_arrays_in_fewer_bytes(tmp_path):
  """Parameters as training leaves them (small floats of one scale): the pack is smaller than the
  same tree's checkpoint written plain, and unpacks to the same bits."""
  src = tmp_path / "src" / "run"
  params = np.random.default_rng(0).normal(0, 0.05, 250_000).astype(np.float32)
  checkpoint.save(str(src / "checkpoint"), _State(np.zeros(1, np.float32), params),
                  {"env_state": True})
  training.drop_env_state(str(src / "checkpoint"))   # what pack sent before it compacted
  plain = os.path.getsize(src / "checkpoint" / checkpoint.FILE)
  parts = carry.pack(str(tmp_path / "src"), str(tmp_path / "out"), "p")
  assert sum(os.path.getsize(p) for p in parts) < 0.9 * plain
  carry.unpack(parts, str(tmp_path / "dest"))
  assert _arrays(str(tmp_path / "dest" / "run"))[".params"].tobytes() == params.tobytes()


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
  with pytest.raises(carry.CarryError, match="would land outside the folder it is extracted"):
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


def _git(repo, *args) -> str:
  return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True,
                        text=True).stdout.strip()


def _repo(path) -> pathlib.Path:
  """A git repository with one commit of a 3,000-byte file, ``runs/`` ignored."""
  os.makedirs(path)
  _git(path, "init", "-q")
  _git(path, "config", "user.name", "t")
  _git(path, "config", "user.email", "t@example.com")
  (path / "code.py").write_bytes(b"x" * 3_000)
  (path / ".gitignore").write_text("runs/\n")
  _git(path, "add", ".")
  _git(path, "commit", "-q", "-m", "first")
  return path


def test_fits_counts_the_tree_and_the_carried_paths_against_the_calls_limit(tmp_path, capsys):
  repo = _repo(tmp_path / "repo")
  (repo / "notes.txt").write_bytes(b"y" * 1_000)   # untracked, not ignored: it travels
  os.makedirs(repo / "runs" / "hc")
  (repo / "runs" / "hc" / "part").write_bytes(b"z" * 5_000)   # ignored: only when carried
  fit = carry.fits([], repo=str(repo))
  assert (fit.tree, fit.tree_files) == (3_000 + 1_000 + len("runs/\n"), 3) and fit.fits
  fit = carry.fits([str(repo / "runs" / "hc")], repo=str(repo), call_mib=9_000 / carry.MIB)
  assert fit.carried == [(str(repo / "runs" / "hc"), 5_000)] and fit.total == 9_006
  assert not fit.fits   # 6 bytes over
  with pytest.raises(SystemExit) as e:
    carry.main(["fits", str(repo / "runs" / "hc"), "--repo", str(repo), "--call-mib",
                str(9_000 / carry.MIB)])
  assert e.value.code == 1 and "over the" in capsys.readouterr().out
  with pytest.raises(carry.CarryError, match="not ignored by git, so it travels with the tree"):
    carry.fits([str(repo / "notes.txt")], repo=str(repo))
  with pytest.raises(carry.CarryError, match="does not exist"):
    carry.fits([str(repo / "runs" / "nothing")], repo=str(repo))
  with pytest.raises(carry.CarryError, match="lies outside the working tree"):
    carry.fits([str(tmp_path)], repo=str(repo))


def test_aside_takes_the_committed_results_out_of_what_travels_and_back_brings_them_whole(
    tmp_path, capsys):
  repo = _repo(tmp_path / "repo")
  for rel, size in (("benchmarks/paper/row/metrics.csv", 4_000),
                    ("benchmarks/multiagent/sumo/checkpoint.npz", 6_000)):
    os.makedirs(repo / os.path.dirname(rel), exist_ok=True)
    (repo / rel).write_bytes(b"r" * size)
  (repo / "benchmarks" / "ablations.py").write_bytes(b"a" * 500)  # code: it stays and travels
  _git(repo, "add", ".")
  _git(repo, "commit", "-q", "-m", "results")
  (repo / "benchmarks" / "paper" / "row" / "notes.md").write_bytes(b"n" * 100)  # uncommitted
  os.makedirs(repo / "runs")
  (repo / "runs" / "pack").write_bytes(b"p" * 5_000)
  limit = (3_000 + 500 + 5_000 + 1_000) / carry.MIB   # the code, the pack, a margin
  with pytest.raises(SystemExit) as e:   # with the results the pack does not fit; aside would
    carry.main(["fits", str(repo / "runs" / "pack"), "--repo", str(repo), "--call-mib",
                str(limit)])
  assert e.value.code == 1
  assert "with `carry.py aside` (benchmarks/paper, benchmarks/multiagent" in capsys.readouterr().out
  assert carry.aside(repo=str(repo)) == ["benchmarks/paper", "benchmarks/multiagent"]
  assert not (repo / "benchmarks" / "paper").exists()
  assert (repo / "benchmarks" / "ablations.py").exists()
  fit = carry.fits([str(repo / "runs" / "pack")], repo=str(repo), call_mib=limit)
  assert fit.tree == 3_000 + 500 + len("runs/\n") and fit.fits
  with pytest.raises(carry.CarryError, match="set aside before and not brought back"):
    carry.aside(repo=str(repo))
  # a checkout brings one back while it is aside: back refuses and moves nothing
  _git(repo, "checkout", "--", "benchmarks/paper")
  with pytest.raises(carry.CarryError, match="exists in the tree again"):
    carry.back(repo=str(repo))
  assert not (repo / "benchmarks" / "multiagent").exists()
  shutil.rmtree(repo / "benchmarks" / "paper")
  assert carry.back(repo=str(repo)) == ["benchmarks/paper", "benchmarks/multiagent"]
  assert _git(repo, "status", "--porcelain") == "?? benchmarks/paper/row/notes.md"
  assert (repo / "benchmarks" / "paper" / "row" / "notes.md").read_bytes() == b"n" * 100
  carry.main(["back", "--repo", str(repo)])
  assert "nothing was set aside" in capsys.readouterr().out
  carry.main(["aside", "--repo", str(repo)])
  assert "commit nothing with -a" in capsys.readouterr().out
  carry.main(["back", "--repo", str(repo)])
  assert "brought back: benchmarks/paper, benchmarks/multiagent" in capsys.readouterr().out


def test_a_parked_pack_leaves_the_tree_and_comes_back_whole_in_a_fresh_clone(tmp_path, capsys):
  repo = _repo(tmp_path / "repo")
  parts = carry.pack(_tree(tmp_path), str(tmp_path / "out"), "hc", part_mb=PART_MB)
  before = _git(repo, "rev-parse", "HEAD")
  commit = carry.park(parts, repo=str(repo), note="HalfCheetah GCRL at 31 M; resume with ...")
  # Two commits: the parts in the first, out of the tree in the second, which writes the ledger.
  assert _git(repo, "rev-list", "--count", f"{before}..HEAD") == "2"
  assert _git(repo, "rev-parse", "HEAD~1") == commit
  held = _git(repo, "ls-tree", "-r", "--name-only", commit)
  assert all(f"benchmarks/parked/hc/{os.path.basename(p)}" in held for p in parts)
  now = _git(repo, "ls-tree", "-r", "--name-only", "HEAD").split()
  assert sorted(now) == [".gitignore", "benchmarks/parked.json", "code.py"]
  assert not (repo / "benchmarks" / "parked").exists() and _git(repo, "status", "--short") == ""
  assert carry.fits([], repo=str(repo)).tree < 3_000 + 1_000   # no call carries the parts
  entry = carry.read_ledger(str(repo))["hc"]
  assert entry["commit"] == commit and [p["file"] for p in entry["parts"]] == [
      os.path.basename(p) for p in parts]
  carry.main(["parked", "--repo", str(repo)])
  assert f"hc: {len(parts)} parts" in capsys.readouterr().out

  clone = tmp_path / "clone"   # the next session's checkout: the history, nothing else
  subprocess.run(["git", "clone", "-q", str(repo), str(clone)], check=True)
  # The parts are read by their git objects, which stay where a landing rewrites the commits.
  ledger = carry.read_ledger(str(clone))
  ledger["hc"]["commit"] = "0" * 40
  (clone / carry.LEDGER).write_text(json.dumps(ledger))
  back = carry.unpark("hc", str(clone / "runs" / "carry"), repo=str(clone))
  assert [open(a, "rb").read() for a in back] == [open(p, "rb").read() for p in parts]
  carry.unpack(back, str(tmp_path / "dest"))
  run = tmp_path / "dest" / "mimax" / "objective=diayn"
  np.testing.assert_array_equal(_arrays(str(run))[".params"],
                                np.linspace(-1, 1, 500, dtype=np.float32))
  with pytest.raises(carry.CarryError, match="exists; nothing was written"):
    carry.unpark("hc", str(clone / "runs" / "carry"), repo=str(clone))

  assert carry.forget("hc", repo=str(clone))["parts"][0]["file"] == "hc.tar.part_000"
  assert carry.read_ledger(str(clone)) == {}
  with pytest.raises(carry.CarryError, match="no pack named 'hc' is parked; parked: none"):
    carry.unpark("hc", str(tmp_path / "again"), repo=str(clone))


def test_park_refuses_a_broken_pack_a_name_parked_twice_and_staged_changes(tmp_path):
  repo = _repo(tmp_path / "repo")
  parts = carry.pack(_tree(tmp_path), str(tmp_path / "out"), "hc", part_mb=PART_MB)
  head = _git(repo, "rev-parse", "HEAD")
  stream = b"".join(open(p, "rb").read() for p in parts)
  short = tmp_path / "short" / "hc.tar.part_000"   # its last parts lost: no list of its files
  os.makedirs(short.parent)
  short.write_bytes(stream[:stream.index(carry.MANIFEST.encode())])
  with pytest.raises(carry.CarryError, match="park: .*not a whole pack.*is not parked"):
    carry.park([str(short)], repo=str(repo))
  (repo / "code.py").write_text("changed")
  _git(repo, "add", "code.py")
  with pytest.raises(carry.CarryError, match="staged changes \\(code.py, ...\\)"):
    carry.park(parts, repo=str(repo))
  assert _git(repo, "rev-parse", "HEAD") == head   # nothing was committed
  _git(repo, "commit", "-q", "-m", "the user's own change")
  carry.park(parts, repo=str(repo))
  with pytest.raises(carry.CarryError, match="'hc' is parked already.*park --replace"):
    carry.park(parts, repo=str(repo))
  with pytest.raises(carry.CarryError, match="--replace, but no pack named 'ant' is parked; "
                     "parked: hc"):
    carry.park(carry.pack(_tree(tmp_path / "ant"), str(tmp_path / "ant_out"), "ant",
                          part_mb=PART_MB), repo=str(repo), replace=True)


def test_a_run_parked_again_after_a_resume_replaces_its_older_pack(tmp_path, capsys):
  repo = _repo(tmp_path / "repo")
  older = carry.pack(_tree(tmp_path / "a"), str(tmp_path / "a_out"), "hc", part_mb=PART_MB)
  first = carry.park(older, repo=str(repo), note="at 31 M")
  newer_tree = _tree(tmp_path / "b")   # the same run further on: its metrics and params moved
  run = os.path.join(newer_tree, "mimax", "objective=diayn")
  with open(os.path.join(run, "metrics.csv"), "a") as f:
    f.write("0,10\n")
  checkpoint.save(os.path.join(run, "checkpoint"),
                  _State(env_state=ENV_STATE, params=np.full(500, 0.5, np.float32)),
                  {"env_state": True, "history": []})
  newer = carry.pack(newer_tree, str(tmp_path / "b_out"), "hc", part_mb=PART_MB)
  carry.main(["park", *newer, "--replace", "--note", "at 62 M", "--repo", str(repo)])
  second = _git(repo, "rev-parse", "HEAD~1")
  assert f"parked in commit {second[:10]}" in capsys.readouterr().out and second != first
  entry = carry.read_ledger(str(repo))["hc"]
  assert (entry["commit"], entry["note"], entry["replaces"]) == (second, "at 62 M", [first])
  back = carry.unpark("hc", str(tmp_path / "into"), repo=str(repo))
  carry.unpack(back, str(tmp_path / "dest"))   # the newer pack comes back, not the older
  np.testing.assert_array_equal(
      _arrays(str(tmp_path / "dest" / "mimax" / "objective=diayn"))[".params"],
      np.full(500, 0.5, np.float32))
  third = carry.park(older, repo=str(repo), replace=True)   # every replaced commit, newest first
  assert carry.read_ledger(str(repo))["hc"]["replaces"] == [second, first]
  carry.main(["parked", "--repo", str(repo)])
  listed = capsys.readouterr().out
  assert f"commit {third[:10]}, parked " in listed and "(replaces 2 older)" in listed
  assert third not in (first, second)


def test_unpark_refuses_a_part_that_is_not_the_one_parked(tmp_path):
  repo = _repo(tmp_path / "repo")
  parts = carry.pack(_tree(tmp_path), str(tmp_path / "out"), "hc", part_mb=PART_MB)
  carry.park(parts, repo=str(repo))
  ledger = carry.read_ledger(str(repo))
  ledger["hc"]["parts"][1]["sha256"] = "0" * 64
  (repo / carry.LEDGER).write_text(json.dumps(ledger))
  into = tmp_path / "into"
  with pytest.raises(carry.CarryError, match="part_001 at .* is not the part that was parked"):
    carry.unpark("hc", str(into), repo=str(repo))
  assert not into.exists()   # all or nothing
  ledger["hc"]["parts"][0]["blob"] = "f" * 40   # an object this clone lacks
  (repo / carry.LEDGER).write_text(json.dumps(ledger))
  with pytest.raises(carry.CarryError, match="part_000 .*cannot be read .*git fetch --unshallow"):
    carry.unpark("hc", str(into), repo=str(repo))


_SCRIPT = pathlib.Path(carry.__file__).with_name("device_call.sh")


def _device_call(cwd, out, *args, extra=None) -> subprocess.CompletedProcess:
  """benchmarks/device_call.sh run in ``cwd`` as on the device: this Python first on the path, the
  repository importable, the stage and the wheels' site under ``cwd``; ``extra`` environment."""
  env = {**os.environ, "OUT": str(out), "STAGE_ROOT": str(cwd), "SITE_DIR": str(cwd / "site"),
         "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ["PATH"],
         "PYTHONPATH": str(_SCRIPT.parents[1]), **(extra or {})}
  return subprocess.run(["bash", str(_SCRIPT), *map(str, args)], cwd=cwd, env=env,
                        capture_output=True, text=True)


def _wheel(folder) -> None:
  """A one-module wheel, ``blxprobe`` (``blxprobe.X == 1``), in ``folder``: a carried wheel."""
  os.makedirs(folder)
  info = "blxprobe-0.1.dist-info"
  files = {"blxprobe.py": "X = 1\n",
           f"{info}/METADATA": "Metadata-Version: 2.1\nName: blxprobe\nVersion: 0.1\n",
           f"{info}/WHEEL": "Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\n"
                            "Tag: py3-none-any\n"}
  files[f"{info}/RECORD"] = "".join(f"{name},,\n" for name in [*files, f"{info}/RECORD"])
  with zipfile.ZipFile(folder / "blxprobe-0.1-py3-none-any.whl", "w") as wheel:
    for name, text in files.items():
      wheel.writestr(name, text)


def test_a_device_call_resumes_from_carried_parts_and_sends_the_run_back(tmp_path):
  device = tmp_path / "device"
  carry.pack(_tree(tmp_path), str(device / ".carry" / "hc"), "hc", part_mb=PART_MB)
  _wheel(device / ".whl-train")
  # The "training": imports the carried wheel, checks that the run was rebuilt from the parts,
  # then adds to it.
  train = ("import os, blxprobe; r = 'runs/hc/mimax/objective=diayn'; "
           "assert os.path.exists(r + '/checkpoint/checkpoint.npz'); "
           "open(r + '/metrics.csv', 'a').write('0,10\\n'); "
           "print('trained, stop by', os.environ['BLX_STOP_BY'])")
  began = time.time()
  done = _device_call(device, tmp_path / "out", "hc", "runs/hc", 60, sys.executable, "-c", train,
                      extra={"RESUME": "1"})
  assert done.returncode == 0, done.stderr + done.stdout
  log = (tmp_path / "out" / "hc.log").read_text()
  assert "unpacked into runs/hc" in log and "trained" in log and "exit status 0" in log
  # training's time limit (blx.training.stop_time) is 15 s before the call's 60 s end
  stop_by = int(log.split("trained, stop by ")[1].split()[0])
  assert began + 45 - 1 <= stop_by <= time.time() + 45
  assert "installed .whl-train" in log and (device / "site" / "blxprobe.py").exists()
  back = sorted(str(p) for p in (tmp_path / "out").glob("hc.tar.part_*"))
  assert back
  carry.unpack(back, str(tmp_path / "home"))
  run = tmp_path / "home" / "mimax" / "objective=diayn"
  assert (run / "metrics.csv").read_text() == "seed,env_steps\n0,5\n0,10\n"
  np.testing.assert_array_equal(_arrays(str(run))[".params"],
                                np.linspace(-1, 1, 500, dtype=np.float32))

  # A second call on the same machine keeps the run it left (the parts are not unpacked over
  # it); one that outlasts its seconds is interrupted, and what it had is still sent back.
  # A limit the call is given is its own.
  slow = ("import os, time; open('runs/hc/late', 'w').write(os.environ['BLX_STOP_BY']); "
          "time.sleep(30)")
  done = _device_call(device, tmp_path / "out2", "hc", "runs/hc", 1, sys.executable, "-c", slow,
                      extra={"BLX_STOP_BY": "123"})
  assert done.returncode == 124
  log = (tmp_path / "out2" / "hc.log").read_text()
  assert "unpacked" not in log and "installed" not in log and "exit status 124" in log
  carry.unpack(sorted(str(p) for p in (tmp_path / "out2").glob("hc.tar.part_*")),
               str(tmp_path / "home2"))
  assert (tmp_path / "home2" / "late").read_text() == "123"
  assert (tmp_path / "home2" / "mimax" / "objective=diayn" / "metrics.csv").read_text().endswith(
      "0,10\n")


def test_two_device_calls_side_by_side_send_their_packs_in_turn(tmp_path):
  # Each call fits its parts beside what $OUT already holds, so a call must not send while the
  # other is sending: with the lock held (another call sending), this one packs and then waits.
  device = tmp_path / "device"
  os.makedirs(device / "runs")
  shutil.copytree(_tree(tmp_path), device / "runs" / "hc")
  lock = device / "blx-send.lock"
  os.makedirs(lock)
  out = tmp_path / "out"
  env = {**os.environ, "OUT": str(out), "STAGE_ROOT": str(device),
         "SITE_DIR": str(device / "site"), "PYTHONPATH": str(_SCRIPT.parents[1]),
         "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ["PATH"]}
  call = subprocess.Popen(["bash", str(_SCRIPT), "hc", "runs/hc", "60", "touch", "runs/hc/late"],
                          cwd=device,
                          env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
  deadline = time.time() + 120
  while not list((device / "stage-hc").glob("hc.tar.part_*")) and time.time() < deadline:
    time.sleep(0.2)
  assert list((device / "stage-hc").glob("hc.tar.part_*")), "the call never packed its run"
  time.sleep(3)
  assert call.poll() is None and not list(out.glob("hc.tar.part_*"))  # waiting for the lock
  os.rmdir(lock)
  stdout, stderr = call.communicate(timeout=120)
  assert call.returncode == 0, stderr + stdout
  assert list(out.glob("hc.tar.part_*")) and not lock.exists()  # sent, and the lock let go


def test_a_device_call_that_leaves_its_run_as_it_found_it_sends_only_parts_left_staged(tmp_path):
  # A finished run: its command only reports, rewriting a summary with the same text. Its last
  # pack holds it, so the call packs nothing and sends nothing that would take another arm's room.
  report = "open('runs/hc/summary.md', 'w').write('the same')"
  device = tmp_path / "device"
  tree = _tree(tmp_path)
  pathlib.Path(tree, "summary.md").write_text("the same")
  carry.pack(tree, str(device / ".carry" / "hc"), "hc", part_mb=PART_MB)
  done = _device_call(device, tmp_path / "out", "hc", "runs/hc", 60, sys.executable, "-c", report,
                      extra={"RESUME": "1"})
  assert done.returncode == 0, done.stderr + done.stdout
  log = (tmp_path / "out" / "hc.log").read_text()
  assert "unpacked into runs/hc" in log and "as this call found it: not packed again" in log
  assert not list((tmp_path / "out").glob("hc.tar.part_*")) and not (device / "stage-hc").exists()

  # Parts an earlier call packed but could not send (no room in its return) are still staged:
  # the next call that leaves the run as it was sends them.
  carry.pack(str(device / "runs" / "hc"), str(device / "stage-hc"), "hc", part_mb=PART_MB)
  done = _device_call(device, tmp_path / "out2", "hc", "runs/hc", 60, sys.executable, "-c",
                      report)
  assert done.returncode == 0, done.stderr + done.stdout
  back = sorted(str(p) for p in (tmp_path / "out2").glob("hc.tar.part_*"))
  assert back and not list((device / "stage-hc").glob("hc.tar.part_*"))
  carry.unpack(back, str(tmp_path / "home"))
  assert (tmp_path / "home" / "summary.md").read_text() == "the same"
  assert (tmp_path / "home" / "mimax" / "objective=diayn" / "metrics.csv").exists()

  # A command that fails before its first chunk ends changes only the run's provenance.json,
  # where it records that it ran: that is not packed again either.
  failed = "open('runs/hc/provenance.json', 'a').write('a segment'); raise SystemExit(1)"
  done = _device_call(device, tmp_path / "out_failed", "hc", "runs/hc", 60, sys.executable, "-c",
                      failed)
  assert done.returncode == 1
  log = (tmp_path / "out_failed" / "hc.log").read_text()
  assert "as this call found it: not packed again" in log
  assert not list((tmp_path / "out_failed").glob("hc.tar.part_*"))

  # A command that changes the run, if only by one file, is packed and sent anew.
  done = _device_call(device, tmp_path / "out3", "hc", "runs/hc", 60, sys.executable, "-c",
                      "open('runs/hc/summary.md', 'w').write('changed')")
  back = sorted(str(p) for p in (tmp_path / "out3").glob("hc.tar.part_*"))
  assert done.returncode == 0 and back
  carry.unpack(back, str(tmp_path / "home3"))
  assert (tmp_path / "home3" / "summary.md").read_text() == "changed"


def test_a_device_call_told_to_resume_never_starts_a_run_anew(tmp_path):
  done = _device_call(tmp_path, tmp_path / "out", "hc", "runs/hc", 60, "touch", "trained",
                      extra={"RESUME": "1"})
  assert done.returncode == 3 and "carry.py unpark hc --into .carry/hc" in done.stderr
  assert not (tmp_path / "trained").exists() and not (tmp_path / "runs").exists()


def test_a_device_call_carries_nothing_back_for_a_run_that_never_reached_a_checkpoint(tmp_path):
  # A new run stopped before its first chunk ended: its directory holds a config.json and no
  # checkpoint, so there is nothing to resume and no part is sent (it would take a returned file).
  start = ("import os, time; os.makedirs('runs/hc/point'); "
           "open('runs/hc/point/config.json', 'w').write('{}'); time.sleep(30)")
  done = _device_call(tmp_path, tmp_path / "out", "hc", "runs/hc", 1, sys.executable, "-c", start)
  assert done.returncode == 124
  assert "holds no checkpoint" in (tmp_path / "out" / "hc.log").read_text()
  assert not list((tmp_path / "out").glob("hc.tar.part_*"))
  assert not (tmp_path / "stage-hc").exists()


def test_a_device_call_on_a_machine_without_the_wheels_says_so_before_it_runs(tmp_path):
  # a fresh machine (the last one went back between calls) with nothing carried: the modules the
  # run needs are missing, and the call says so instead of running COMMAND into an import error
  done = _device_call(tmp_path, tmp_path / "out", "hc", "runs/hc", 60, "touch", "trained",
                      extra={"NEEDS": "blxprobe_absent json"})
  assert done.returncode == 2 and "finds no blxprobe_absent here" in done.stderr
  assert "carry .whl-train" in done.stderr and not (tmp_path / "trained").exists()
  # carried wheels are installed first, so the same check passes on the module they bring
  _wheel(tmp_path / ".whl-train")
  done = _device_call(tmp_path, tmp_path / "out", "hc", "runs/hc", 60, "touch", "trained",
                      extra={"NEEDS": "blxprobe"})
  assert done.returncode == 0 and (tmp_path / "trained").exists()


def test_a_device_call_names_a_bad_call(tmp_path):
  done = _device_call(tmp_path, tmp_path / "out", "hc", "runs/hc", "ten", "true")
  assert done.returncode == 2 and "SECONDS must be a whole number" in done.stderr
  done = _device_call(tmp_path, tmp_path / "out", "hc", "runs/hc")
  assert done.returncode == 2 and "usage:" in done.stderr
