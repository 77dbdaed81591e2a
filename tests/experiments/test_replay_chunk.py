"""benchmarks/replay_chunk.py: one seed of a run, replayed from its checkpoint."""

import os
import shutil

import jax
import numpy as np
import pytest

from blx.experiments import runs
from blx.training import checkpoint
from tests.experiments import load_benchmark
from tests.experiments.test_cli import TINY_CONFIG

replay_chunk = load_benchmark("replay_chunk")


@pytest.fixture(scope="module")
def stopped_and_whole(tmp_path_factory):
  """The same two-seed run of two chunks: stopped after its first chunk (its checkpoint then),
  and trained whole."""
  root = tmp_path_factory.mktemp("replay")
  spec = runs.RunSpec(env="point", objective="diayn", objective_options={"num_skills": 3},
                      ppo={**TINY_CONFIG, "num_timesteps": 1600}, seeds=(0, 1),
                      env_params={"episode_length": 20})
  stopped, whole = str(root / "stopped"), str(root / "whole")

  def killed(row):
    raise KeyboardInterrupt

  with pytest.raises(KeyboardInterrupt):
    runs.train_run(spec, stopped, progress=killed)
  runs.train_run(spec, whole, progress=False)
  return stopped, whole


def test_replaying_the_next_chunk_gives_the_runs_own_parameters(stopped_and_whole):
  # Seed 1 replayed from the checkpoint after chunk 1, for one chunk's iterations, ends where the
  # whole run's seed 1 ended: the replay is the run's computation (vmapped there, alone here).
  stopped, whole = stopped_and_whole
  rows, error, state = replay_chunk.replay(stopped, 1, show=False)
  assert error is None
  per_chunk = len(rows)
  assert per_chunk > 1 and rows[0]["iteration"] == per_chunk  # it starts after chunk 1
  assert all(np.isfinite(r["policy/log_ratio_max"]) for r in rows)
  whole_run = runs.load_run(whole)
  ours = jax.tree.leaves(jax.device_get(state.params.policy))
  theirs = [np.asarray(x)[1] for x in jax.tree.leaves(whole_run.params.policy)]
  assert len(ours) == len(theirs)
  for a, b in zip(ours, theirs):
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)
  assert float(state.env_steps) == float(checkpoint.read_meta(
      os.path.join(whole, "checkpoint"))["history"][-1]["env_steps"])


def test_a_seed_the_run_does_not_have_is_refused(stopped_and_whole):
  with pytest.raises(SystemExit, match=r"--seed 7: the run's seeds are \[0, 1\]"):
    replay_chunk.replay(stopped_and_whole[0], 7, show=False)


def test_a_directory_without_a_run_or_a_checkpoint_is_one_line_of_error(tmp_path, capsys):
  with pytest.raises(SystemExit) as e:
    replay_chunk.main([str(tmp_path), "--seed", "0"])
  assert e.value.code == 2
  assert "is not a blx run directory (no config.json)" in capsys.readouterr().err


def test_a_checkpoint_within_a_chunk_replays_from_its_own_iteration(stopped_and_whole, tmp_path,
                                                                     monkeypatch, capsys):
  # The stopped run's checkpoint, moved one iteration on as a run in segments
  # (train(checkpoint_segments=...)) checkpoints within a chunk: the replay counts from there.
  stopped = str(tmp_path / "stopped")
  shutil.copytree(stopped_and_whole[0], stopped)
  trainer, state, meta = replay_chunk.seed_state(stopped, 1)
  per_chunk = trainer.iterations_per_chunk
  _, _, moved = replay_chunk.replay(stopped, 1, 1, show=False)
  whole = jax.tree.map(lambda x: np.stack([x, x]), moved)   # both seeds' places
  checkpoint.save(os.path.join(stopped, "checkpoint"), whole,
                  {**meta, "partial": {"iterations": 1, "time": 1.0, "metrics": {}}})
  rows, error, _ = replay_chunk.replay(stopped, 1, 2, show=True)
  assert error is None and [r["iteration"] for r in rows] == [per_chunk + 1, per_chunk + 2]
  assert (f"after chunk 1 and 1 iterations of the next (iteration {per_chunk + 1}"
          in capsys.readouterr().out)
