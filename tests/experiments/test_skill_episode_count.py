"""benchmarks/skill_episode_count.py: how the MI an MI-max row reads depends on the episodes per
skill (and a continuous prior's latents) it is read from, on features whose answer is known:
episodes that differ in their course (a value of their own), episodes that differ in nothing but
the states they hold, and latents that share a value or not."""

import argparse
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, objectives
from tests.experiments import EchoEnv, load_benchmark

skill_episode_count = load_benchmark("skill_episode_count")
SCALE = 5.0


def _read(scored, k, draws=1, steps=None, seed=0, latents=None):
  return skill_episode_count.read_subsets(jnp.asarray(scored), jax.random.PRNGKey(seed), k, draws,
                                          SCALE, steps, latents)


def test_episodes_with_courses_of_their_own_read_more_mi_the_fewer_are_read():
  # Two skills, two episodes each, every state of an episode at one value (its course): skill 0's
  # episodes at -2 and 0, skill 1's at 0 and +2. Read from both episodes, H(s) = 1.5 ln 2 and
  # H(s|z) = ln 2: MI = 0.5 ln 2. From one episode of each, the two skills share their value in a
  # quarter of the draws (MI 0) and are apart in the rest (ln 2): 0.75 ln 2 on average.
  scored = np.array([[-2.0, 0.0], [0.0, 2.0]], np.float32)[:, :, None, None] * np.ones(
      (1, 1, 6, 1), np.float32)
  both = _read(scored, 2)
  np.testing.assert_allclose(both["mi"]["mean"], [0.5 * np.log(2)], rtol=1e-5)
  np.testing.assert_allclose(both["cond_entropy"]["mean"], [np.log(2)], rtol=1e-5)
  one = _read(scored, 1, draws=2000)
  np.testing.assert_allclose(one["mi"]["mean"], [0.75 * np.log(2)], atol=0.03)
  np.testing.assert_allclose(one["cond_entropy"]["mean"], [0.0], atol=1e-6)
  # One evaluation of one episode reads 0 or ln 2: std sqrt(3) / 4 ln 2.
  np.testing.assert_allclose(one["mi"]["std"], [np.sqrt(3) / 4 * np.log(2)], atol=0.03)
  # Fewer states of the same episodes change nothing: the courses make this gap.
  fewer = _read(scored, 2, steps=2)
  np.testing.assert_allclose(fewer["mi"]["mean"], both["mi"]["mean"], rtol=1e-5)


def test_episodes_alike_read_the_same_mi_from_any_number_and_fewer_states_read_less_spread():
  # Every episode of skill s walks the same 8 distinct values (a ramp, skill s at 10 s + t / 10):
  # H(s|z) = ln 8 from any number of episodes, MI = ln 2. Read from 4 evenly spaced states of each,
  # H(s|z) = ln 4: the states alone make that gap.
  ramp = np.arange(8, dtype=np.float32) / 10
  scored = (np.array([-1.0, 1.0], np.float32)[:, None] + ramp)[:, None, :, None] * np.ones(
      (1, 3, 1, 1), np.float32)
  for k in (1, 2, 3):
    got = _read(scored, k, draws=5)
    np.testing.assert_allclose(got["cond_entropy"]["mean"], [np.log(8)], rtol=1e-5)
    np.testing.assert_allclose(got["mi"]["mean"], [np.log(2)], rtol=1e-5)
  fewer = _read(scored, 3, draws=5, steps=4)
  np.testing.assert_allclose(fewer["cond_entropy"]["mean"], [np.log(4)], rtol=1e-5)
  assert list(skill_episode_count.evenly_spaced(8, 4)) == [0, 2, 5, 7]


def test_the_readings_hold_the_states_per_skill_fixed_where_they_split_evenly():
  ramp = np.arange(8, dtype=np.float32) / 10
  scored = jnp.asarray((np.array([-1.0, 1.0], np.float32)[:, None] + ramp)[:, None, :, None]
                       * np.ones((1, 4, 1, 1), np.float32))
  out = skill_episode_count.readings(scored, jax.random.PRNGKey(0), [1, 2, 4], 3, SCALE, 8)
  # k = 1 reads 8 of 8 steps, k = 2 four of each, k = 4 two of each: 8, 4, 2 distinct values.
  for k, distinct in ((1, 8), (2, 4), (4, 2)):
    np.testing.assert_allclose(out[f"cond_entropy_fixed_states/{k}"], [np.log(distinct)],
                               rtol=1e-5)
    np.testing.assert_allclose(out[f"cond_entropy/{k}"], [np.log(8)], rtol=1e-5)
  assert skill_episode_count.fixed_state_sizes([1, 2, 3, 4], 8, 8) == [1, 2, 4]
  assert skill_episode_count.fixed_state_sizes([1, 2, 4], 16, 8) == [2, 4]
  assert "mi_fixed_states/3" not in skill_episode_count.readings(
      scored, jax.random.PRNGKey(0), [3], 1, SCALE, 8)


def test_the_pool_holds_every_skills_episodes_in_the_scored_window():
  run = SimpleNamespace(env=envs.episode(EchoEnv(), 8),
                        policy=lambda p, o, z, key=None, deterministic=False:
                        (jnp.argmax(z, -1).astype(jnp.float32) - 1.5)[:, None],
                        objective=objectives.diayn(num_skills=4, obs_indices=(0,), obs_scale=5.0))
  scored = jax.jit(lambda k: skill_episode_count.pooled_episodes(run, {}, k, 3,
                                                                 deterministic=True))(
      jax.random.PRNGKey(0))
  assert scored.shape == (4, 3, 4, 1)  # the last half of 8 steps
  np.testing.assert_allclose(scored[..., 0].mean((1, 2)), [-1.5, -0.5, 0.5, 1.5])


def test_bad_options_are_refused_naming_what_is_valid(tmp_path, monkeypatch, capsys):
  run = SimpleNamespace(directory=str(tmp_path), env=envs.episode(EchoEnv(), 8),
                        spec=SimpleNamespace(seeds=(0, 1), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=4, obs_indices=(0,)))
  monkeypatch.setattr(skill_episode_count.runs, "load_run", lambda directory: run)
  for argv, message in (([str(tmp_path), "--sizes", "2,30"], "30 is more than the --pool of 20"),
                        ([str(tmp_path), "--sizes", "0,2"], "at least 1"),
                        ([str(tmp_path), "--sizes", "a"], "comma-separated whole numbers"),
                        ([str(tmp_path), "--pool", "0"], "--pool 0"),
                        ([str(tmp_path), "--states", "7", "--sizes", "2,4"],
                         "no size of [2, 4] splits it evenly"),
                        ([str(tmp_path), "--seeds", "3"], "the run has 2 seeds"),
                        ([str(tmp_path), "--plot", "--draws", "5", "--seeds", "0"],
                         "--seeds, --draws: choose the analysis; --plot draws its JSON"),
                        ([str(tmp_path), "--plot"], "no result to plot")):
    with pytest.raises(SystemExit):
      skill_episode_count.main(argv)
    assert message in capsys.readouterr().err
  with pytest.raises(SystemExit):   # a categorical prior's every skill is read
    skill_episode_count.main([str(tmp_path), "--latents", "4"])
  assert "--latents is for a continuous prior" in capsys.readouterr().err
  run.objective, run.spec.objective = objectives.cdiayn(obs_indices=(0,)), "cdiayn"
  for argv, message in (([str(tmp_path), "--latents", "1,4"], "at least 2"),
                        ([str(tmp_path), "--pool", "5", "--latents", "4,10"], "--pool of 5")):
    with pytest.raises(SystemExit):
      skill_episode_count.main(argv)
    assert message in capsys.readouterr().err
  parser = argparse.ArgumentParser()
  for name, objective in (("fixed_gcrl", objectives.fixed_gcrl(obs_indices=(0,))),
                          ("gail", objectives.gail(obs_indices=(0,)))):
    with pytest.raises(SystemExit):
      skill_episode_count._check_run(SimpleNamespace(
          directory="runs/x", spec=SimpleNamespace(objective=name), objective=objective), parser)
    assert "valid: 'categorical' or a continuous one such as 'uniform'" in capsys.readouterr().err
  assert skill_episode_count._check_run(SimpleNamespace(
      directory="runs/x", spec=SimpleNamespace(objective="cdiayn"),
      objective=objectives.cdiayn(obs_indices=(0,))), parser)


def test_a_continuous_priors_readings_draw_m_of_the_pooled_latents():
  # Three latents, one episode each, every state at one value: latents 0 and 1 share -1, latent 2
  # sits at +1. Read with all three, H(s) = H(2/3, 1/3) and H(s|z) = 0. Read two at random, the
  # pair {0, 1} (a third of the draws) reads MI 0 and the others ln 2: 2/3 ln 2 on average.
  scored = np.array([-1.0, -1.0, 1.0], np.float32)[:, None, None, None] * np.ones(
      (1, 1, 4, 1), np.float32)
  three = _read(scored, 1, latents=3)
  h = -(2 / 3 * np.log(2 / 3) + 1 / 3 * np.log(1 / 3))
  np.testing.assert_allclose(three["mi"]["mean"], [h], rtol=1e-5)
  two = _read(scored, 1, draws=3000, latents=2)
  np.testing.assert_allclose(two["mi"]["mean"], [2 / 3 * np.log(2)], atol=0.03)
  # The readings key a continuous prior's by the number of latents, m beside k.
  out = skill_episode_count.readings(jnp.asarray(scored), jax.random.PRNGKey(0), [1], 2, SCALE, 4,
                                     latent_counts=[2, 3])
  np.testing.assert_allclose(out["mi/3_latents/1"], three["mi"]["mean"], rtol=1e-5)
  assert {"mi/2_latents/1", "mi_fixed_states/3_latents/1",
          "cond_entropy_std/2_latents/1"} <= set(out)
  assert "mi/1" not in out


def test_a_continuous_priors_pool_rolls_each_drawn_latent_out_pool_times():
  run = SimpleNamespace(env=envs.episode(EchoEnv(), 8),
                        policy=lambda p, o, z, key=None, deterministic=False: z[:, :1],
                        objective=objectives.cdiayn(obs_indices=(0,), obs_scale=5.0))
  scored = jax.jit(lambda k: skill_episode_count.pooled_episodes(run, {}, k, 3,
                                                                 deterministic=True))(
      jax.random.PRNGKey(0))
  assert scored.shape == (3, 3, 4, 1)   # 3 latents drawn, 3 episodes of each, last half of 8
  # Each latent's episodes echo its own first number, drawn from the prior: three distinct values.
  np.testing.assert_allclose(scored[..., 0], scored[:, :1, :1, 0] * np.ones((1, 3, 4)))
  assert len(np.unique(np.round(np.asarray(scored[:, 0, 0, 0]), 5))) == 3
