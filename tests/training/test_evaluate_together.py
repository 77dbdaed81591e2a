"""``training.evaluate_together``: the paper's evaluator steps its episodes in one rollout with
PPO's evaluation episodes and scores what each would alone; other evaluators run after PPO's."""

from __future__ import annotations

import dataclasses

import jax
import numpy as np
import pytest

from blx import envs, metrics, objectives, training
from tests.conftest import make_env
from tests.training.tiny import SMALL


@pytest.fixture(scope="module")
def setup():
  env = make_env("point")
  objective = objectives.make("diayn", obs_indices="pos_xy", env=env, num_skills=2)
  trainer = training.make_trainer(env, objective, dataclasses.replace(SMALL, num_eval_envs=3))
  params = training.policy_params(jax.jit(trainer.init)(jax.random.PRNGKey(0)))
  return env, objective, trainer, params


def _alone(trainer, evaluator, params, key, evaluator_key):
  ours = jax.jit(trainer.evaluate)(params, key)
  theirs = jax.jit(lambda p, k: evaluator(trainer.policy, p, k))(params, evaluator_key)
  return {**ours, **theirs}


def test_the_papers_evaluator_runs_with_ppos_episodes_and_scores_the_same(setup, monkeypatch):
  env, objective, trainer, params = setup
  evaluator = metrics.mimax_evaluator(env, objective, num_latents=2, episodes_per_latent=2,
                                      num_goals=2, last_steps=10)
  calls = []
  real = envs.rollout_together
  monkeypatch.setattr(envs, "rollout_together", lambda batches: calls.append(
      [jax.tree.leaves(b.state)[0].shape[0] for b in batches]) or real(batches))
  keys = jax.random.PRNGKey(1), jax.random.PRNGKey(2)
  together = jax.jit(training.evaluate_together(trainer, evaluator))(params, *keys)
  assert calls == [[3, 8]]  # one rollout: PPO's 3 envs beside the evaluator's (2 + 2) x 2
  alone = _alone(trainer, evaluator, params, *keys)
  assert set(together) == set(alone) and "eval/mi" in together and "eval/episode_reward" in together
  for k in alone:
    np.testing.assert_allclose(together[k], alone[k], rtol=1e-5, atol=1e-6, err_msg=k)


def test_other_evaluators_run_after_ppos(setup):
  env, objective, trainer, params = setup
  keys = jax.random.PRNGKey(1), jax.random.PRNGKey(2)
  plain = lambda policy, p, key: {"eval/seen": jax.random.uniform(key)}  # noqa: E731
  out = jax.jit(training.evaluate_together(trainer, plain))(params, *keys)
  assert float(out["eval/seen"]) == float(jax.random.uniform(keys[1]))
  np.testing.assert_allclose(out["eval/episode_reward"],
                             jax.jit(trainer.evaluate)(params, keys[0])["eval/episode_reward"])
  # The paper's evaluator on another env object than PPO's runs alone, with the same metrics.
  other = envs.create("point")
  evaluator = metrics.mimax_evaluator(other, objective, num_latents=2, episodes_per_latent=2,
                                      num_goals=2, last_steps=10)
  out = jax.jit(training.evaluate_together(trainer, evaluator))(params, *keys)
  alone = _alone(trainer, evaluator, params, *keys)
  for k in alone:
    np.testing.assert_allclose(out[k], alone[k], rtol=1e-6, err_msg=k)
