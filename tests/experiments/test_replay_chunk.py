"""benchmarks/replay_chunk.py: one seed of a run, replayed from its checkpoint."""

import os

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
