"""The one rollout loop (``envs.rollout``) and the episode mask its callers share."""

from __future__ import annotations

from types import SimpleNamespace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs
from blx.envs.env import State


class _Counter:
  """A stand-in env: the observation counts steps plus the action; it ends at step ``end``."""

  observation_size, action_size = 1, 1

  def __init__(self, end: float):
    self.end = end

  def reset(self, key):
    return State(data=jnp.zeros(()), obs=jnp.zeros(1), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    t = state.data + 1.0
    return state.replace(data=t, obs=t[None] + action, reward=t,
                         done=(t >= self.end).astype(jnp.float32))


def test_rollout_steps_every_env_with_its_own_key_each_step_and_records_what_is_asked():
  env = _Counter(end=100.0)
  state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), 3))
  act = lambda obs, key: jax.random.uniform(key, (obs.shape[0], 1))

  final, (obs, action, reward) = envs.rollout(
      env, act, state, 4, jax.random.PRNGKey(1),
      lambda s, a, n: (n.obs, a, n.reward))
  assert obs.shape == (4, 3, 1) and action.shape == (4, 3, 1)
  np.testing.assert_allclose(reward, [[1] * 3, [2] * 3, [3] * 3, [4] * 3])
  np.testing.assert_allclose(obs, reward[..., None] + action)   # the recorded action was applied
  np.testing.assert_allclose(final.data, 4.0)
  # One fresh key per step: no two steps draw the same actions.
  assert len({tuple(np.asarray(a).ravel().round(6)) for a in action}) == 4


def test_alive_before_counts_the_step_an_episode_ends_on_and_nothing_after():
  done = jnp.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 1, 0]], jnp.float32)   # [T=4, N=3]
  np.testing.assert_array_equal(envs.alive_before(done),
                                [[1, 1, 1], [1, 1, 1], [0, 1, 1], [0, 1, 0]])


def test_training_evaluation_totals_stop_at_the_episode_end():
  # Through the trainer's evaluate: an env that ends at step 3 of 6 scores 1 + 2 + 3.
  import dataclasses

  from blx.objectives import task
  from blx.training import networks, ppo
  from tests.training.tiny import SMALL

  config = dataclasses.replace(SMALL, num_eval_envs=2)
  learner = ppo.make_learner(1, 1, task(), config)
  params = ppo.PolicyParams(normalizer=networks.init_stats(1),
                            policy=learner.policy_net.init(jax.random.PRNGKey(0), jnp.zeros(1)))
  out = ppo.evaluate(learner, _Counter(end=3.0), 6, params, jax.random.PRNGKey(0))
  assert float(out["eval/episode_env_reward"]) == 6.0
  assert float(out["eval/episode_length"]) == 3.0


class _Pose(NamedTuple):
  qpos: jax.Array


class _Walker(_Counter):
  """``_Counter`` whose physics state has a pose: qpos = (steps taken,)."""

  def reset(self, key):
    return State(data=_Pose(jnp.zeros(1)), obs=jnp.zeros(1), reward=jnp.zeros(()),
                 done=jnp.zeros(()))

  def step(self, state, action):
    q = state.data.qpos + 1.0
    return state.replace(data=_Pose(q), obs=q, reward=q[0], done=(q[0] >= self.end).astype(
        jnp.float32))


def test_render_holds_the_pose_an_episode_ended_in():
  from blx.experiments import render
  run = SimpleNamespace(env=envs.episode(_Walker(end=2.0), 5),
                        objective=SimpleNamespace(conditions_policy=False),
                        policy=lambda params, obs, z: jnp.zeros((obs.shape[0], 1)))
  qpos = render.rollout_qpos(run, None, jnp.zeros((2, 0)), jax.random.PRNGKey(0), steps=5)
  np.testing.assert_array_equal(qpos[..., 0], [[0, 1, 2, 2, 2, 2]] * 2)   # reset pose, then steps


def test_batches_rolled_out_together_record_what_each_would_alone():
  # Two evaluations of one env in one loop: each batch acts on its own envs' observations with its
  # own per-step keys, so its records are those of envs.rollout on it alone.
  env = _Counter(end=100.0)

  def batch(n, key, scale):
    state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(n), n))
    act = lambda obs, k: scale * jax.random.uniform(k, (obs.shape[0], 1)) + obs  # noqa: E731
    return envs.Episodes(env, state, act, lambda s, a, nxt: (nxt.obs, a), key, 5)

  a, b = batch(2, jax.random.PRNGKey(7), 1.0), batch(3, jax.random.PRNGKey(8), -10.0)
  together = envs.rollout_together([a, b])
  for one, records in zip((a, b), together):
    _, alone = envs.rollout(env, one.act, one.state, one.steps, one.key, one.record)
    assert records[0].shape == alone[0].shape
    np.testing.assert_array_equal(records[0], alone[0])
    np.testing.assert_array_equal(records[1], alone[1])
  assert float(together[1][1].max()) <= 0.0 < float(together[0][1].min())  # acts kept apart


def test_batches_run_together_only_on_one_env_for_one_length():
  env = _Counter(end=100.0)
  state = jax.vmap(env.reset)(jax.random.split(jax.random.PRNGKey(0), 2))
  act = lambda obs, k: obs  # noqa: E731
  record = lambda s, a, n: n.obs  # noqa: E731
  first = envs.Episodes(env, state, act, record, jax.random.PRNGKey(0), 4)
  with pytest.raises(ValueError, match="batch 1 runs 4 steps on .* share one env object"):
    envs.rollout_together([first, first._replace(env=_Counter(end=100.0))])
  with pytest.raises(ValueError, match="batch 1 runs 3 steps"):
    envs.rollout_together([first, first._replace(steps=3)])
  with pytest.raises(ValueError, match="no batches"):
    envs.rollout_together([])
