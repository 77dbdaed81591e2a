"""benchmarks/action_noise.py: the spread of a policy's sampled actions about their mean, on
stand-in policies whose noise is known."""

import sys
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, objectives
from blx.envs.env import State
from blx.objectives.targets import Target
from tests.experiments import load_benchmark

action_noise = load_benchmark("action_noise")


def _gaussian(params, obs, z, *, key, deterministic):
  """Action mean ``params["mean"]`` in every dim; noise std ``params["std"]``, times the state's
  latent where there is one (so each state has its own noise)."""
  mean = jnp.full(obs.shape[:-1] + (3,), params["mean"])
  if deterministic:
    return mean
  std = params["std"] * (z[..., :1] if z is not None else 1.0)
  return mean + std * jax.random.normal(key, mean.shape)


def test_the_std_of_the_draws_is_the_policys_noise_at_each_state():
  obs = jnp.zeros((4, 5))
  z = jnp.array([[0.5], [1.0], [2.0], [4.0]])
  out = jax.jit(lambda k: action_noise.noise_at(_gaussian, {"mean": 0.0, "std": 0.05}, obs, z, k,
                                                4000))(jax.random.PRNGKey(0))
  np.testing.assert_allclose(out["action_std"], 0.05 * z[:, 0], rtol=0.04)
  # |N(0, s)| has mean s * sqrt(2 / pi)
  np.testing.assert_allclose(out["mean_abs_action"], 0.05 * z[:, 0] * np.sqrt(2 / np.pi),
                             rtol=0.04)
  assert out["action_std"].shape == (4,)


def test_a_policy_without_latents_and_the_share_beyond_099():
  # mean 0.98, std 0.01: a draw is beyond 0.99 one standard deviation above the mean, P = 0.159
  out = action_noise.noise_at(_gaussian, {"mean": 0.98, "std": 0.01}, jnp.zeros((2, 5)), None,
                              jax.random.PRNGKey(1), 20000)
  np.testing.assert_allclose(out["saturated_share"], 0.1587, atol=0.01)
  np.testing.assert_allclose(out["mean_abs_action"], 0.98, atol=1e-3)
  # a policy that does not sample has no spread
  still = action_noise.noise_at(_gaussian, {"mean": 0.3, "std": 0.0}, jnp.zeros((2, 5)), None,
                                jax.random.PRNGKey(2), 8)
  np.testing.assert_allclose(still["action_std"], 0.0, atol=1e-7)


def test_each_action_dim_is_read_apart():
  # stds 0.05, 0.2 and 0.4 on the three dims: the mean over dims is 0.2167, each dim its own.
  def shaky(params, obs, z, *, key, deterministic):
    mean = jnp.zeros(obs.shape[:-1] + (3,))
    return mean if deterministic else mean + jnp.array([0.05, 0.2, 0.4]) * jax.random.normal(
        key, mean.shape)

  out = action_noise.noise_at(shaky, {}, jnp.zeros((3, 5)), None, jax.random.PRNGKey(4), 6000)
  assert out["action_std_by_action"].shape == (3, 3)
  np.testing.assert_allclose(out["action_std_by_action"], np.tile([0.05, 0.2, 0.4], (3, 1)),
                             rtol=0.05)
  np.testing.assert_allclose(out["action_std"], 0.65 / 3, rtol=0.05)


class _Counter:
  """Observes its step count; actions do nothing."""

  observation_size, action_size = 2, 3

  def reset(self, key):
    return State(data=None, obs=jnp.zeros(2), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(obs=state.obs + jnp.array([1.0, 0.0]))


def _skill_noise(params, obs, z=None, *, key=None, deterministic=False):
  """Noise std 0.1 for skill 0, 0.2 for skill 1, 0.3 for skill 2; 0.1 without a skill."""
  mean = jnp.zeros(obs.shape[:-1] + (3,))
  if deterministic:
    return mean
  std = 0.1 * (1.0 + (jnp.argmax(z, -1)[..., None] if z is not None else 0.0))
  return mean + std * jax.random.normal(key, mean.shape)


def test_a_seed_is_read_over_its_skills_evaluation_episodes_or_its_plain_ones():
  env = envs.episode(_Counter(), 8)
  skills = SimpleNamespace(env=env, policy=_skill_noise,
                           objective=objectives.diayn(num_skills=3, obs_indices=(0,)))
  out = jax.jit(lambda k: action_noise.seed_noise(skills, {}, k, 4, 3000))(jax.random.PRNGKey(0))
  # every skill's one-hot, its states weighted alike: the mean of 0.1, 0.2 and 0.3
  np.testing.assert_allclose(out["action_std"], 0.2, rtol=0.04)
  target = Target(samples=jnp.zeros((2, 1)), log_prob=None, name="zero", means=None)
  plain = SimpleNamespace(env=env, policy=_skill_noise,
                          objective=objectives.gail(target=target, obs_indices=(0,)))
  out = jax.jit(lambda k: action_noise.seed_noise(plain, {}, k, 4, 3000))(jax.random.PRNGKey(0))
  np.testing.assert_allclose(out["action_std"], 0.1, rtol=0.04)


class _Tracer:
  """Observes its step count and the sum of its first action dim: a skill that acts at its index
  leaves its index as the ratio of the two."""

  observation_size, action_size = 2, 3

  def reset(self, key):
    return State(data=None, obs=jnp.zeros(2), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(obs=state.obs + jnp.stack([1.0, action[0]]))


def _true_to_its_state(params, obs, z, *, key, deterministic):
  """Acts at its skill's index; its noise is small (0.01) where the state shows that skill, and
  large (1.0) at a state another skill visited."""
  skill = jnp.argmax(z, -1).astype(jnp.float32)
  mean = jnp.stack([skill, jnp.zeros_like(skill), jnp.zeros_like(skill)], -1)
  if deterministic:
    return mean
  shown = obs[..., 1] / jnp.maximum(obs[..., 0], 1.0)
  std = jnp.where(jnp.abs(shown - skill) < 0.5, 0.01, 1.0)[..., None]
  return mean + std * jax.random.normal(key, mean.shape)


def test_each_state_is_read_under_the_skill_whose_episode_visited_it():
  run = SimpleNamespace(env=envs.episode(_Tracer(), 8), policy=_true_to_its_state,
                        objective=objectives.diayn(num_skills=3, obs_indices=(0,)))
  out = jax.jit(lambda k: action_noise.seed_noise(run, {}, k, 4, 500))(jax.random.PRNGKey(0))
  np.testing.assert_allclose(out["action_std"], 0.01, rtol=0.1)  # a state read under another
  # skill's latent would draw with std 1


@pytest.mark.parametrize("argv, message", [
    (["--samples", "1"], "--samples 1: give 2 or more"),
    (["--episodes", "0"], "--episodes 0: give 1 or more"),
    ([], "no run directory at"),
])
def test_bad_input_is_named(monkeypatch, capsys, tmp_path, argv, message):
  monkeypatch.setattr(sys, "argv", ["action_noise.py", str(tmp_path / "nothing"), *argv])
  with pytest.raises(SystemExit) as exit_:
    action_noise.main()
  assert exit_.value.code == 2 and message in capsys.readouterr().err
