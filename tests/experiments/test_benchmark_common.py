"""benchmarks/common.py: the one-iteration-per-chunk config that the timing benchmarks
(train_throughput.py, profile_ppo.py) run a jitted chunk with, the timing of a jitted call
(chunk_costs.py, host_loop.py), the vmapped env step timed by env_throughput.py and
cheetah_step.py, how fall_analysis.py and skill_spread.py pick a run's seeds and name it, and the
joints that a run's actions drive (fall_analysis.py --noise-on, action_noise.py)."""

import argparse
import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, training
from blx.objectives import task
from tests.conftest import make_env
from tests.experiments import load_benchmark

common = load_benchmark("common")


@pytest.mark.parametrize("num_envs", [2048, 16384, 65536])
def test_one_iteration_per_chunk_is_a_valid_config_at_any_benchmarked_scale(num_envs):
  # The timing benchmarks once asked for 10**12 steps, which PPOConfig refuses (2**31 - 1 at most).
  config = training.ppo_defaults("ant", num_envs=num_envs, batch_size=num_envs // 2,
                                 num_minibatches=32)
  one = common.one_iteration_per_chunk(config, chunks=100)
  assert one.num_evals == 100
  assert one.num_timesteps == 100 * config.env_steps_per_iteration
  assert (one.num_envs, one.batch_size, one.num_minibatches) == (num_envs, num_envs // 2, 32)


def test_the_trainer_runs_one_iteration_per_chunk():
  env = make_env("point")
  config = common.one_iteration_per_chunk(training.ppo_defaults("point"), chunks=7)
  trainer = training.make_trainer(env, task(), config)
  assert (trainer.iterations_per_chunk, trainer.num_chunks) == (1, 7)


def test_the_first_call_is_kept_apart_and_every_timed_call_gets_its_own_arguments():
  seen = []

  def fn(i):
    seen.append(i)
    return jnp.asarray(i)

  first, times = common.time_calls(fn, lambda i: (i,), repeats=3)
  assert seen == [0, 1, 2, 3]  # one untimed first call (the compile), then 3 timed ones
  assert len(times) == 3 and first >= 0 and all(t >= 0 for t in times)


def test_env_step_runner_sums_the_rewards_of_the_env_steps_it_runs():
  env = envs.unwrap(make_env("point"))
  run, (state, actions) = common.env_step_runner(env, num_envs=3, steps=4)
  assert actions.shape == (4, 3, env.action_size) and state.obs.shape[0] == 3
  total, s = 0.0, state
  for a in actions:
    s = jax.vmap(env.step)(s, a)
    total += float(s.reward.sum())
  np.testing.assert_allclose(float(run(state, actions)), total, rtol=1e-5)


def test_seed_positions_name_the_bad_ones_and_the_valid_range():
  assert common.seed_positions(None, 3) == [0, 1, 2]
  assert common.seed_positions("2,0", 3) == [2, 0]
  with pytest.raises(ValueError, match=r"--seeds 3,-1: the run has 3 seeds, positions 0\.\.2"):
    common.seed_positions("0,3,-1", 3)
  with pytest.raises(ValueError, match=r"--seed 'a': give comma-separated positions"):
    common.seed_positions("a", 3, "--seed")


def test_run_labels_name_the_env_edits_of_an_ablation_run():
  from blx.experiments import runs
  plain = runs.RunSpec(env="humanoid", objective="airl", objective_options={}, ppo={},
                       seeds=(0, 1))
  edited = runs.RunSpec(env="humanoid", objective="airl", objective_options={}, ppo={},
                        seeds=(0, 1), env_params={"edits": {"global_options.reset_actions": 0.5}})
  assert common.run_label(plain) == "airl on humanoid, 2 seeds"
  assert (common.run_label(edited)
          == "airl on humanoid (global_options.reset_actions 0.5), 2 seeds")
  assert common.run_label(plain, "seed 1") == "airl on humanoid, seed 1"


def test_run_labels_name_the_ppo_settings_off_the_envs_row():
  from blx.experiments import runs
  spec = runs.RunSpec(env="halfcheetah", objective="gcrl", objective_options={},
                      ppo={"max_grad_norm": 5, "num_evals": 40}, seeds=(0, 1))
  assert common.run_label(spec) == (
      "gcrl on halfcheetah, 2 seeds; PPO max_grad_norm 5 (default None)")
  assert common.run_label(spec, "seed 1").endswith(", seed 1; PPO max_grad_norm 5 (default None)")
  # an analysis rolls out its own episodes: how the run's return episodes acted is not named
  mean = dataclasses.replace(spec, ppo={**spec.ppo, "eval_actions": "mean"})
  assert common.run_label(mean) == common.run_label(spec)


def test_a_json_write_that_fails_halfway_leaves_the_last_whole_file(tmp_path):
  import json
  path = str(tmp_path / "analysis.json")
  common.write_json(path, {"mi": [1.0]})
  # json.dump writes "mi" and its list before it reaches the set it cannot encode.
  with pytest.raises(TypeError):
    common.write_json(path, {"mi": [2.0], "bad": {1, 2}})
  with open(path) as f:
    assert json.load(f) == {"mi": [1.0]}
  assert sorted(p.name for p in tmp_path.iterdir()) == ["analysis.json"]


def test_the_analyses_share_their_run_options():
  import argparse
  parser = argparse.ArgumentParser()
  common.add_analysis_arguments(parser, "a run")
  args = parser.parse_args(["runs/x", "--seeds", "0,2", "--deterministic", "--out", "a.json"])
  assert (args.run, args.seeds, args.deterministic, args.out) == ("runs/x", "0,2", True,
                                                                   "a.json")
  args = parser.parse_args(["runs/x"])
  assert (args.seeds, args.deterministic, args.out) == (None, False, None)


def test_seed_table_gives_each_trailing_element_its_mean_and_std_over_seeds():
  table = common.seed_table({"lgr": [1.0, 3.0], "reach": [[1.0, -2.0], [3.0, -4.0]]}, "what")
  assert table.splitlines() == ["| what | mean +- std over seeds |", "| --- | ---: |",
                                "| lgr | 2.000 +- 1.000 |",
                                "| reach | 2.000 +- 1.000, -3.000 +- 1.000 |"]


def test_load_picked_names_a_missing_run(tmp_path, capsys):
  parser = argparse.ArgumentParser()
  with pytest.raises(SystemExit):
    common.load_picked(parser, str(tmp_path / "nothing"), None)
  assert "no run directory at" in capsys.readouterr().err


def test_the_humanoid_names_its_actions_by_the_joints_they_drive():
  env = make_env("humanoid")
  names = common.action_names(envs.episode(env, 10))  # through a wrapper
  assert len(names) == env.action_size == 17
  assert names[:4] == ("agent1/abdomen_z", "agent1/abdomen_y", "agent1/abdomen_x",
                       "agent1/right_hip_x")
  assert names[-1] == "agent1/left_elbow"


def test_an_env_without_a_mujoco_model_numbers_its_actions():
  stand_in = type("StandIn", (), {"action_size": 2})()
  assert common.action_names(stand_in) == ("action 0", "action 1")
