"""A chunk run in segments (``train(checkpoint_segments=...)``): the same run, checkpointed within
the chunk, and resumed from there, with the same or another cut."""

from __future__ import annotations

import shutil
import time

import jax
import numpy as np
import pytest

from blx import envs, training
from blx.training import checkpoint, loop
from tests.training.tiny import SMALL, reach_latent

# two chunks of five iterations each
CONFIG = SMALL.replace(num_timesteps=2 * 5 * SMALL.env_steps_per_iteration, num_evals=2)
# the row's wall-clock entries, which no two runs share
CLOCK = ("time", "steps_per_second", "eta_seconds", "compile_seconds")


def _env():
  return envs.create("point", episode_length=20)


def _same_run(a, b):
  for x, y in zip(jax.tree.leaves(a.state), jax.tree.leaves(b.state), strict=True):
    np.testing.assert_array_equal(x, y)
  assert len(a.metrics) == len(b.metrics) == 2
  for row_a, row_b in zip(a.metrics, b.metrics):
    assert {k: v for k, v in row_a.items() if k not in CLOCK} == (
        {k: v for k, v in row_b.items() if k not in CLOCK})


@pytest.mark.xla_defaults  # bitwise the same run: under XLA's defaults (tests/conftest.py)
def test_a_chunk_in_segments_is_the_same_run_and_resumes_from_within_a_chunk(tmp_path, monkeypatch,
                                                                            capsys):
  monkeypatch.delenv("BLX_CHECKPOINT_SEGMENTS", raising=False)   # "none" below means none
  env = _env()
  assert training.make_trainer(env, reach_latent(), CONFIG).iterations_per_chunk == 5
  whole = training.train(env, reach_latent(), CONFIG, progress=False)
  # a segment of one iteration, checkpointed after each: the same iterations, the same rows
  dones = []
  _same_run(whole, training.train(env, reach_latent(), CONFIG, progress=False,
                                  checkpoint_dir=str(tmp_path / "ones"), checkpoint_segments=5,
                                  on_segment=dones.append))
  # and each segment within a chunk (not a chunk's last, which its evaluation reports) is handed
  # on where it ends; without progress=True nothing is printed
  per_iteration = CONFIG.env_steps_per_iteration
  assert [(d.chunk, d.iterations, d.iterations_per_chunk) for d in dones] == [
      (c, i, 5) for c in (1, 2) for i in (1, 2, 3, 4)]
  assert [d.env_steps for d in dones] == [
      ((c - 1) * 5 + i) * per_iteration for c in (1, 2) for i in (1, 2, 3, 4)]
  assert {(d.total_steps, d.checkpoint_dir) for d in dones} == {
      (10 * per_iteration, str(tmp_path / "ones"))}
  assert all(d.steps_per_second > 0 and d.eta_seconds > 0 for d in dones)
  assert "[blx] steps" not in capsys.readouterr().err

  # Two segments (the chunk's 5 iterations cut into 3 + 2): stopped, as a device call's time
  # limit stops it, after the checkpoint of the second chunk's first segment.
  saves, save = [], checkpoint.save

  def save_then_stop(directory, tree, meta, **kwargs):
    save(directory, tree, meta, **kwargs)
    saves.append((meta["chunk"], (meta.get("partial") or {}).get("iterations")))
    if len(saves) == 3:
      raise KeyboardInterrupt

  monkeypatch.setattr(checkpoint, "save", save_then_stop)
  directory = str(tmp_path / "ckpt")
  with pytest.raises(KeyboardInterrupt):
    training.train(env, reach_latent(), CONFIG, progress=False, checkpoint_dir=directory,
                   checkpoint_segments=2)
  monkeypatch.setattr(checkpoint, "save", save)
  # within the first chunk after iteration 3, its end, within the second after iteration 3
  assert saves == [(0, 3), (1, None), (1, 3)]
  meta = checkpoint.read_meta(directory)
  # where it stands, as the interruption says it and as a reader of the checkpoint does
  assert not training.checkpoint_finished(meta)
  assert training.checkpoint_progress(meta) == "1 of 2 chunks and 3 iterations of the next"
  assert "holds 1 of 2 chunks and 3 of 5 iterations of the next: call train(" in (
      capsys.readouterr().err)
  assert meta["env_steps"] == 8 * CONFIG.env_steps_per_iteration and len(meta["history"]) == 1
  # the first three iterations' statistics are kept for the chunk's row
  assert np.shape(meta["partial"]["metrics"]["loss/total"]["values"]) == (1, 3)

  # Resumed with another cut (segments of one iteration: the second chunk's fourth, then its
  # fifth), the run ends as the uninterrupted one, bit for bit, and its second row, a mean over
  # all five of the chunk's iterations, is the same.
  kept = str(tmp_path / "kept")
  shutil.copytree(directory, kept)
  resumed = training.train(env, reach_latent(), CONFIG, progress=True, checkpoint_dir=directory,
                           resume=True, checkpoint_segments=5)
  _same_run(whole, resumed)
  # progress=True prints a line for the segment within the chunk (the fourth iteration), then
  # the chunk's line with its evaluation
  lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("[blx] steps")]
  assert len(lines) == 2
  assert lines[0].startswith(f"[blx] steps {9 * per_iteration:,}/{10 * per_iteration:,}  ")
  assert lines[0].endswith("(4 of 5 iterations of chunk 2; checkpointed)")
  assert lines[1].startswith(f"[blx] steps {10 * per_iteration:,}/{10 * per_iteration:,}  ")
  assert "partial" not in checkpoint.read_meta(directory)
  assert training.checkpoint_finished(checkpoint.read_meta(directory))
  assert resumed.metrics[1]["time"] > meta["partial"]["time"]
  # and with no segments (the chunk's last two iterations in one)
  _same_run(whole, training.train(env, reach_latent(), CONFIG, progress=False,
                                  checkpoint_dir=kept, resume=True))


@pytest.mark.parametrize("segments, message", [
    (0, "checkpoint_segments=0: give a whole number of segments per chunk, 1 to 4 (this run's"),
    (5, "checkpoint_segments=5: give a whole number"),
    (2.0, "checkpoint_segments=2.0: give a whole number"),
    (True, "checkpoint_segments=True"),
])
def test_a_bad_number_of_segments_is_named_with_the_valid_ones(segments, message):
  with pytest.raises(ValueError, match=message.replace("(", r"\(")):
    training.segment_length(4, segments)


def test_the_number_of_segments_comes_from_the_environment_where_not_given(monkeypatch):
  monkeypatch.delenv("BLX_CHECKPOINT_SEGMENTS", raising=False)
  assert training.segment_length(10) == 10   # one segment: the whole chunk
  monkeypatch.setenv("BLX_CHECKPOINT_SEGMENTS", "4")
  assert training.segment_length(10) == 3    # 3 + 3 + 3 + 1
  assert training.segment_length(10, 2) == 5   # an argument wins
  monkeypatch.setenv("BLX_CHECKPOINT_SEGMENTS", "half")
  with pytest.raises(ValueError, match=r"\$BLX_CHECKPOINT_SEGMENTS='half': give a whole number "
                                       r"of segments per chunk, 1 to 10"):
    training.segment_length(10)


def test_a_time_limit_stops_after_a_checkpointed_segment_and_the_run_resumes_the_same(
    tmp_path, monkeypatch, capsys):
  monkeypatch.delenv("BLX_CHECKPOINT_SEGMENTS", raising=False)
  monkeypatch.delenv("BLX_STOP_BY", raising=False)   # the run trained whole has no limit
  env = _env()
  whole = training.train(env, reach_latent(), CONFIG, progress=False)
  # A limit already past: the first segment always runs (there is no pace yet to judge it by),
  # is checkpointed, and the run stops before the second, whatever the machine's speed.
  directory = str(tmp_path / "ckpt")
  with pytest.raises(training.TimeLimitReached) as stopped:
    training.train(env, reach_latent(), CONFIG, progress=False, checkpoint_dir=directory,
                   checkpoint_segments=2, stop_by=time.time() - 1)
  assert isinstance(stopped.value, KeyboardInterrupt)   # ended as Ctrl-C ends a run
  err = capsys.readouterr().err
  assert "[blx] time limit: stopping before iterations 4-5 of chunk 1, which would end about" in err
  assert ("[blx] stopped at the time limit; the checkpoint in " + directory + " holds 0 of 2 chunks "
          "and 3 of 5 iterations of the next: call train(") in err
  meta = checkpoint.read_meta(directory)
  assert meta["partial"]["iterations"] == 3 and meta["history"] == []
  # Resumed under a limit far off (from the environment), it runs to the end: the same run.
  monkeypatch.setenv("BLX_STOP_BY", str(time.time() + 1e6))
  _same_run(whole, training.train(env, reach_latent(), CONFIG, progress=False,
                                  checkpoint_dir=directory, resume=True, checkpoint_segments=2))


def test_the_time_limit_judges_the_next_segment_by_the_pace_of_those_before(monkeypatch):
  now = [100.0]
  monkeypatch.setattr(loop.time, "time", lambda: now[0])
  clock = loop._SegmentClock()
  now[0] = 130.0
  clock.ended(3, evaluated=True)        # no segment without an evaluation yet: 10 s an iteration
  assert clock.next_ends(2, evaluates=False) == 150.0
  now[0] = 140.0
  clock.ended(2, evaluated=False)       # 5 s an iteration
  assert clock.next_ends(3, evaluates=False) == 155.0
  now[0] = 165.0
  clock.ended(3, evaluated=True)        # 15 s for 3 iterations: 10 s of it the evaluation
  assert clock.next_ends(2, evaluates=False) == 175.0
  assert clock.next_ends(3, evaluates=True) == 190.0
  # the next segment (iterations 1-3 of the chunk, per_chunk 5) would end at 180
  left = [(1, 0, 3), (1, 3, 2)]
  loop._stop_if_late(180.0, clock, left, 5)   # ends at the limit: runs
  loop._stop_if_late(None, clock, left, 5)    # no limit
  loop._stop_if_late(100.0, clock, [], 5)     # nothing left to run
  with pytest.raises(training.TimeLimitReached, match="would end 1 s past the limit"):
    loop._stop_if_late(179.0, clock, left, 5)
  # a segment that ends its chunk adds the evaluation's 10 s
  with pytest.raises(training.TimeLimitReached, match="would end 10 s past the limit"):
    loop._stop_if_late(190.0, clock, [(1, 0, 5)], 5)   # 165 + 5 x 5 + 10


def test_the_time_limit_comes_from_the_environment_where_not_given_and_bad_ones_are_named(
    monkeypatch):
  monkeypatch.delenv("BLX_STOP_BY", raising=False)
  assert training.stop_time() is None
  monkeypatch.setenv("BLX_STOP_BY", " 1700000000 ")
  assert training.stop_time() == 1.7e9
  assert training.stop_time(5) == 5.0      # an argument wins
  monkeypatch.setenv("BLX_STOP_BY", "soon")
  with pytest.raises(ValueError, match=r"\$BLX_STOP_BY='soon': give the time limit as a Unix "
                                       r"time in seconds, e\.g\. \$\(\( \$\(date \+%s\) \+ 3600"):
    training.stop_time()
  for bad in (float("nan"), float("inf"), True, "1700000000"):
    with pytest.raises(ValueError, match=r"stop_by=.*: give the time limit as a Unix time"):
      training.stop_time(bad)
