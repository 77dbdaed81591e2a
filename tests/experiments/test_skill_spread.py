"""benchmarks/skill_spread.py: where a discrete-skill row's MI goes, on features whose skill means,
episode offsets and stride swing are known."""

import argparse
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, objectives
from tests.experiments import EchoEnv, load_benchmark

skill_spread = load_benchmark("skill_spread")

MEANS = np.array([-1.5, -0.5, 0.5, 1.5], np.float32)


def _features(period: int = 10, steps: int = 40) -> np.ndarray:
  """``[K, 2, T, 1]``: skill k at MEANS[k], swinging +-0.5 in a square wave of ``period`` steps;
  its first episode 0.1 below that, its second 0.1 above."""
  t = np.arange(steps)
  square = np.where(t % period < period // 2, 0.5, -0.5).astype(np.float32)
  offset = np.array([-0.1, 0.1], np.float32)
  x = MEANS[:, None, None] + square[None, None, :] + offset[None, :, None]
  return x[..., None]


def test_the_variance_splits_into_skills_episodes_and_the_stride():
  out = jax.jit(lambda x: skill_spread.spread(x, 5.0, 20, 10))(jnp.asarray(_features()))
  within, episodes, skills = 0.25, 0.01, MEANS.var()
  total = within + episodes + skills
  np.testing.assert_allclose(out["share_within_episode"], [within / total], rtol=1e-4)
  np.testing.assert_allclose(out["share_between_episodes"], [episodes / total], rtol=1e-3)
  np.testing.assert_allclose(out["share_between_skills"], [skills / total], rtol=1e-4)
  np.testing.assert_allclose(out["stride_std"], [0.5], rtol=1e-4)
  np.testing.assert_allclose(out["skill_gap"], [1.0], rtol=1e-5)
  np.testing.assert_allclose(out["gap_over_stride"], [2.0], rtol=1e-4)
  np.testing.assert_allclose(np.asarray(out["skill_means"])[0], MEANS, atol=1e-6)


def test_a_swing_that_reaches_the_neighbours_costs_mi_and_the_smoothing_gives_it_back():
  # Within an episode index, skill k's upper state is skill k+1's lower one. Per episode index the
  # states take 5 values, two with probability 1/8 and three with 1/4; the two episode offsets
  # double that. So H(s) = 2 ln 8 / 8 + 3 ln 4 / 4 + ln 2, H(s|z) = 2 ln 2 and MI = 0.866 < ln 4.
  # A 10-step mean removes the whole swing of a 10-step period: every skill is back at its own
  # points and the skills are fully separate.
  out = jax.jit(lambda x: skill_spread.spread(x, 5.0, 20, 10))(jnp.asarray(_features()))
  mi = 2 * np.log(8) / 8 + 3 * np.log(4) / 4 + np.log(2) - 2 * np.log(2)
  np.testing.assert_allclose(out["mi"], [mi], rtol=1e-4)
  np.testing.assert_allclose(out["cond_entropy"], [2 * np.log(2)], rtol=1e-4)
  np.testing.assert_allclose(out["effective_skills"], [np.exp(mi)], rtol=1e-4)
  np.testing.assert_allclose(out["mi_smoothed"], [np.log(4)], rtol=1e-5)
  # A window shorter than the period leaves swing, and with it overlap.
  short = jax.jit(lambda x: skill_spread.spread(x, 5.0, 20, 3))(jnp.asarray(_features()))
  assert short["mi_smoothed"][0] < np.log(4) - 0.1


def test_a_skill_beyond_the_range_costs_its_share_of_the_mi_and_the_wide_bins_give_it_back():
  # Four skills held at one value each (two episodes, 0.1 apart): three inside [-5, 5], one at
  # 6.5, outside. The estimator counts that skill's states in N but in no bin, so the MI is
  # (3/4) ln 4 however well it is separated; the same bins over [-10, 10] count it: ln 4.
  means = np.array([-1.5, -0.5, 0.5, 6.5], np.float32)
  x = means[:, None, None] + np.array([-0.05, 0.05], np.float32)[None, :, None]
  x = jnp.asarray(np.repeat(x, 20, axis=2)[..., None])            # [4, 2, 20, 1]
  out = jax.jit(lambda x: skill_spread.spread(x, 5.0, 20, 10))(x)
  np.testing.assert_allclose(out["share_out_of_range"], [0.25], rtol=1e-6)
  np.testing.assert_allclose(out["mi"], [0.75 * np.log(4)], rtol=1e-5)
  np.testing.assert_allclose(out["mi_wide"], [np.log(4)], rtol=1e-5)
  # Inside the range the wide bins are the protocol's bins: the same MI.
  inside = jax.jit(lambda x: skill_spread.spread(x, 5.0, 20, 10))(jnp.asarray(_features()))
  np.testing.assert_allclose(inside["mi_wide"], inside["mi"], rtol=1e-5)
  assert float(inside["share_out_of_range"][0]) == 0.0


def test_the_trailing_mean_averages_the_window_up_to_each_step():
  x = jnp.asarray(np.random.default_rng(0).normal(size=(2, 7, 3)).astype(np.float32))
  got = np.asarray(skill_spread.trailing_mean(x, 3))
  want = np.stack([x[:, max(0, t - 2):t + 1].mean(1) for t in range(7)], axis=1)
  np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


def _skill_policy(params, obs, z, key=None, deterministic=False):
  return (jnp.argmax(z, -1).astype(jnp.float32) - 1.5)[:, None]  # skill k at MEANS[k]


def test_the_protocol_episodes_give_every_skill_its_episodes():
  run = SimpleNamespace(env=envs.episode(EchoEnv(), 8), policy=_skill_policy,
                        objective=objectives.diayn(num_skills=4, obs_indices=(0,), obs_scale=5.0))
  states = jax.jit(lambda k: skill_spread.episodes(run, {}, k, deterministic=True))(
      jax.random.PRNGKey(0))
  assert states.shape == (4, skill_spread.EPISODES, 8, 1)
  np.testing.assert_allclose(states[:, :, :, 0].mean((1, 2)), MEANS)
  out = skill_spread.spread(states, 5.0, 4, 2)
  np.testing.assert_allclose(out["mi"], [np.log(4)], rtol=1e-5)
  np.testing.assert_allclose(out["share_between_skills"], [1.0], rtol=1e-5)


def test_a_run_without_discrete_skills_is_refused_with_the_valid_prior(capsys):
  parser = argparse.ArgumentParser()
  run = SimpleNamespace(directory="runs/x", spec=SimpleNamespace(objective="cdiayn"),
                        objective=objectives.cdiayn(obs_indices=(0,)))
  with pytest.raises(SystemExit):
    skill_spread._check_run(run, parser)
  err = capsys.readouterr().err
  assert "cdiayn" in err and "'uniform'" in err and "valid: 'categorical'" in err
  skill_spread._check_run(SimpleNamespace(
      directory="runs/y", spec=SimpleNamespace(objective="diayn"),
      objective=objectives.diayn(obs_indices=(0,))), parser)


def test_the_command_refuses_a_seed_the_run_does_not_have(tmp_path, monkeypatch, capsys):
  run = SimpleNamespace(directory=str(tmp_path), env=envs.episode(EchoEnv(), 8),
                        spec=SimpleNamespace(seeds=(0, 1), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=4, obs_indices=(0,)))
  monkeypatch.setattr(skill_spread.runs, "load_run", lambda directory: run)
  for argv, message in (([str(tmp_path), "--seeds", "0,2"], "--seeds 2: the run has 2 seeds"),
                        ([str(tmp_path), "--plot", "--seed", "5"], "--seed 5: the run has 2"),
                        ([str(tmp_path), "--window", "0"], "--window 0: give 1..4"),
                        ([str(tmp_path), "--plot", "--seeds", "0"], "--seeds: not used by --plot"),
                        ([str(tmp_path), "--seed", "1"], "the analysis takes --seeds")):
    with pytest.raises(SystemExit):
      skill_spread.main(argv)
    assert message in capsys.readouterr().err
