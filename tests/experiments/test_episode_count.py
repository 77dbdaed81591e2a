"""benchmarks/episode_count.py: how the energy distance a set of episodes reads depends on how many
episodes it holds, on states whose answer is known in closed form."""

from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, metrics, objectives
from blx.objectives.targets import Target
from tests.experiments import load_benchmark

episode_count = load_benchmark("episode_count")

# Two point modes of equal weight at -1 and +1: a set of episodes whose states sit at the modes, a
# share p of them at +1, reads (2p - 1)^2 (the V-statistic: 2 E|X-Y| = 2, E|X-X'| = 4p(1-p),
# E|Y-Y'| = 1).
TARGET = jnp.repeat(jnp.array([-1.0, 1.0]), 50)[:, None]
# Jitted once: eagerly, each of the many small energy distances dispatches op by op.
distances = jax.jit(episode_count.episode_distances)
expected = jax.jit(episode_count.expected_distance, static_argnums=2)
subsets = jax.jit(episode_count.subset_distances, static_argnums=(2, 3))


def _expected(q: float, m: int, k: int) -> float:
  """The mean of (2p - 1)^2 over sets of k of m episodes drawn without replacement, a share q of
  them at +1: the pool's own distance plus 4 Var(p), Var(p) = q (1 - q) (m - k) / (k (m - 1))."""
  return (2 * q - 1) ** 2 + 4 * q * (1 - q) * (m - k) / (k * (m - 1))


def test_a_sets_distance_is_the_energy_distance_of_its_pooled_states():
  key_x, key_y, key_k = jax.random.split(jax.random.PRNGKey(0), 3)
  states = jax.random.normal(key_x, (12, 7, 2)) + jnp.arange(12.0)[:, None, None] / 4
  target = jax.random.normal(key_y, (30, 2)) * 2.0
  to_target, between = distances(states, target)
  for kept in (jnp.ones(12), (jax.random.uniform(key_k, (12,)) < 0.4).astype(jnp.float32),
               jnp.zeros(12).at[5].set(1.0)):
    pooled = states[np.asarray(kept, bool)].reshape(-1, 2)
    np.testing.assert_allclose(episode_count.set_distance(to_target, between, kept),
                               metrics.energy_distance(pooled, target), rtol=1e-4, atol=1e-5)


def test_one_mode_per_episode_reads_higher_on_fewer_episodes_by_the_scatter_of_its_shares():
  m = 40
  sign = jnp.where(jnp.arange(m) % 2 == 0, 1.0, -1.0)
  states = jnp.broadcast_to(sign[:, None, None], (m, 3, 1))  # each episode at one mode
  to_target, between = distances(states, TARGET)
  for k in (1, 4, 10, m):
    closed = float(expected(to_target, between, k))
    np.testing.assert_allclose(closed, (m - k) / (k * (m - 1)), atol=1e-5)
    drawn = subsets(to_target, between, k, 4000, jax.random.PRNGKey(k))
    np.testing.assert_allclose(float(drawn.mean()), closed, atol=0.02)
  one, quick, final, pool = (float(expected(to_target, between, k))
                             for k in (1, 4, 10, m))
  np.testing.assert_allclose([one, pool], [1.0, 0.0], atol=1e-5)  # one mode; an even split
  assert quick > final + 0.1                                     # the quick protocol reads higher


def test_episodes_that_each_cover_both_modes_read_alike_on_any_number():
  states = jnp.broadcast_to(jnp.array([-1.0, 1.0])[None, :, None], (40, 2, 1))
  to_target, between = distances(states, TARGET)
  for k in (1, 4, 10):
    np.testing.assert_allclose(expected(to_target, between, k), 0.0,
                               atol=1e-5)
    drawn = subsets(to_target, between, k, 50, jax.random.PRNGKey(0))
    np.testing.assert_allclose(drawn, 0.0, atol=1e-5)


def test_a_set_larger_than_the_pool_or_empty_is_refused():
  for size in (0, 6):
    with pytest.raises(ValueError, match="size must be 1 to the pool's 5 episodes"):
      episode_count.subset_distances(jnp.zeros(5), jnp.zeros((5, 5)), size, 3,
                                     jax.random.PRNGKey(0))


class _ModePerEpisode:
  """Each episode draws one of the modes, -1 or +1, at its reset and stays there."""

  observation_size, action_size = 1, 1

  def reset(self, key):
    from blx.envs.env import State
    side = jnp.where(jax.random.bernoulli(key), 1.0, -1.0)
    return State(data=side, obs=side[None], reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    return state


def _run():
  target = Target(samples=TARGET, log_prob=None, name="two points",
                  means=jnp.array([[-1.0], [1.0]]))
  return SimpleNamespace(env=envs.episode(_ModePerEpisode(), 8),
                         policy=lambda params, obs, z=None, key=None, deterministic=False:
                         jnp.zeros(obs.shape[:-1] + (1,)),
                         objective=objectives.gail(target=target, obs_indices=(0,)))


def test_analyse_rolls_the_pool_out_and_reads_each_size_as_the_closed_form():
  m, sizes = 30, (1, 3, 30)
  out = jax.jit(lambda k: episode_count.analyse(_run(), {}, k, pool=m, sizes=sizes, draws=3000,
                                                deterministic=False))(jax.random.PRNGKey(3))
  q = float(out["episode_mode_share/1"])  # the pool's share of episodes at +1
  np.testing.assert_allclose(float(out["episode_mode_share/0"]), 1 - q, rtol=1e-6)
  assert 0 < q < 1
  np.testing.assert_allclose(out["energy_distance_pool"], (2 * q - 1) ** 2, atol=1e-5)
  np.testing.assert_allclose(out["episode_to_target"], 1.0, atol=1e-5)
  for k in sizes:
    np.testing.assert_allclose(out[f"energy_distance/{k}"], _expected(q, m, k), atol=1e-5)
    np.testing.assert_allclose(out[f"energy_distance_draws/{k}"], _expected(q, m, k), atol=0.03)
  np.testing.assert_allclose(out[f"energy_distance/{m}"], out["energy_distance_pool"], atol=1e-5)
  np.testing.assert_allclose(out[f"energy_distance_std/{m}"], 0.0, atol=1e-5)


def test_the_command_refuses_what_it_cannot_read(tmp_path, monkeypatch, capsys):
  run = SimpleNamespace(spec=SimpleNamespace(seeds=(0, 1), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=4, obs_indices=(0,)))
  monkeypatch.setattr(episode_count.runs, "load_run", lambda directory: run)
  for argv, message in (([], "is not a D-min objective"),
                        (["--sizes", "1,50"], "--sizes must lie in 1 to --pool (40)"),
                        (["--sizes", "four"], "--sizes takes comma-separated whole numbers"),
                        (["--pool", "1"], "--pool must be at least 2")):
    with pytest.raises(SystemExit):
      episode_count.main([str(tmp_path), *argv])
    assert message in capsys.readouterr().err
  with pytest.raises(SystemExit, match="does not exist"):
    episode_count.main([str(tmp_path), "--plot"])
