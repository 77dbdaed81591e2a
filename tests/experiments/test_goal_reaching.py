"""benchmarks/goal_reaching.py: the LGR split into the goals beyond the policy's reach and the
inferred latents' excess, on states and stand-in policies whose answer is known."""

import json
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, metrics, objectives
from blx.envs.env import State
from tests.experiments import load_benchmark

goal_reaching = load_benchmark("goal_reaching")


def _episodes(*values):
  """One latent's states ``[M=1, T=4, D=1]`` repeating ``values`` over time."""
  return jnp.tile(jnp.asarray(values, jnp.float32), 4 // len(values))[None, :, None]


def test_the_lgr_splits_into_reach_and_the_inferred_latents_excess():
  goals = jnp.array([[-3.0], [0.0]])
  # goal -3's latent runs at 2 (the wrong way); goal 0's strides between -1 and 1
  reached = jnp.stack([_episodes(2.0), _episodes(-1.0, 1.0)])
  # the policy's latents: one strides about 0, one runs at 2; nothing reaches below -1
  candidates = jnp.stack([_episodes(-1.0, 1.0), _episodes(2.0)])
  out = goal_reaching.decompose(reached, goals, candidates)
  np.testing.assert_allclose(out["goal_lgr"], [5.0, 1.0])
  np.testing.assert_allclose(out["lgr"], 3.0)
  # each goal's best latent is the striding one: 3 from -3 on average, 1 from 0
  np.testing.assert_allclose(out["goal_best_lgr"], [3.0, 1.0])
  np.testing.assert_array_equal(out["best_candidate"], [0, 0])
  np.testing.assert_allclose(out["inference_excess"], 1.0)
  # goal -3 lies 3 beyond the nearest mean state (0); goal 0 is one (a latent's mean is 0)
  np.testing.assert_allclose(out["goal_reach"], [3.0, 0.0])
  np.testing.assert_allclose(out["reach_lgr"], 1.5)
  np.testing.assert_allclose(out["reach_low"], [0.0])
  np.testing.assert_allclose(out["reach_high"], [2.0])
  np.testing.assert_allclose(out["reached_mean"], [[2.0], [0.0]])
  np.testing.assert_allclose(out["reached_std"], [[0.0], [1.0]])


def test_a_latents_spread_splits_into_within_and_between_episodes():
  # latent 0: two episodes striding between -1 and 1 about the same mean (all within);
  # latent 1: two episodes holding 1 and 3 (all between)
  striding = jnp.concatenate([_episodes(-1.0, 1.0), _episodes(1.0, -1.0)])
  holding = jnp.concatenate([_episodes(1.0), _episodes(3.0)])
  out = goal_reaching.spread(jnp.stack([striding, holding]))
  np.testing.assert_allclose(out["within_std"], [[1.0], [0.0]])
  np.testing.assert_allclose(out["between_std"], [[0.0], [1.0]])
  # the two parts' squares are the variance of all of a latent's states
  mixed = jax.random.normal(jax.random.PRNGKey(0), (3, 5, 7, 2)) + jnp.arange(5.0)[:, None, None]
  parts = goal_reaching.spread(mixed)
  np.testing.assert_allclose(parts["within_std"] ** 2 + parts["between_std"] ** 2,
                             mixed.var((1, 2)), rtol=1e-5)
  # decompose reports the candidates' parts, and the summary their mean over candidates
  out = goal_reaching.decompose(jnp.stack([holding]), jnp.array([[0.0]]),
                                jnp.stack([striding, holding]))
  np.testing.assert_allclose(out["candidate_within_std"], [[1.0], [0.0]])
  summary = goal_reaching.summary_values({k: v[None] for k, v in out.items()})
  assert set(summary) == set(goal_reaching.SUMMARY)
  np.testing.assert_allclose(summary["spread_within"], [[0.5]])
  np.testing.assert_allclose(summary["spread_between"], [[0.5]])


def test_following_reads_how_far_and_which_way_skills_go_toward_their_goals():
  goals = np.array([[3.0, 4.0], [0.0, 2.0], [-1.0, 0.0]])
  # half of each goal, the same way: share 0.5, cosine 1, the farthest mean 2.5 from the origin
  half = goal_reaching.following(goals, goals / 2, np.array([[1.0, 0.0], [0.0, -3.0]]))
  np.testing.assert_allclose(half["farthest"], 2.5)
  np.testing.assert_allclose(half["goal_share"], 0.5)
  np.testing.assert_allclose(half["goal_cosine"], 1.0)
  np.testing.assert_allclose(half["reached_norm"], 2.0)
  # turned a right angle (same speeds): the share stays, the cosine is 0; backwards, -1
  turned = goals[:, ::-1] * np.array([1.0, -1.0])
  np.testing.assert_allclose(goal_reaching.following(goals, turned, goals)["goal_cosine"], 0.0,
                             atol=1e-12)
  np.testing.assert_allclose(goal_reaching.following(goals, -goals, goals)["goal_cosine"], -1.0)
  # the share is a median: one skill that runs past its goal does not move it
  ran = goals * np.array([[0.8], [0.9], [3.0]])
  np.testing.assert_allclose(goal_reaching.following(goals, ran, goals)["goal_share"], 0.9)
  # a skill standing still (or a goal at the origin) has no direction: share and cosine 0
  still = goal_reaching.following(goals[:1], np.zeros((1, 2)), goals[:1])
  assert float(still["goal_share"]) == 0.0 and float(still["goal_cosine"]) == 0.0
  # over seeds: the leading axes are kept
  seeds = goal_reaching.following(np.stack([goals, goals]), np.stack([goals / 2, goals]),
                                  np.zeros((2, 1, 2)))
  np.testing.assert_allclose(seeds["goal_share"], [0.5, 1.0])
  np.testing.assert_allclose(seeds["farthest"], [2.5, 5.0])


def test_following_is_summarised_only_where_the_latents_are_goals():
  assert goal_reaching.latents_are_goals(objectives.gcrl(obs_indices=(0, 1)).spec)
  assert not goal_reaching.latents_are_goals(objectives.cdiayn(obs_indices=(0, 1)).spec)
  assert not goal_reaching.latents_are_goals(
      objectives.diayn(num_skills=4, obs_indices=(0, 1)).spec)
  goals = jnp.array([[2.0], [-2.0]])
  values = goal_reaching.decompose(jnp.stack([_episodes(1.0), _episodes(-1.0)]), goals,
                                   jnp.stack([_episodes(1.0), _episodes(-1.0)]))
  values = {**values, "candidates": goals}
  values = {k: np.asarray(v)[None] for k, v in values.items()}
  assert set(goal_reaching.summary_values(values)) == set(goal_reaching.SUMMARY)
  summary = goal_reaching.summary_values(values, latent_goals=True)
  assert set(summary) == set(goal_reaching.SUMMARY + goal_reaching.FOLLOWING)
  np.testing.assert_allclose(summary["goal_share"], [0.5])
  np.testing.assert_allclose(summary["goal_cosine"], [1.0])
  np.testing.assert_allclose(summary["farthest"], [1.0])


class _Limited:
  """Its one observed dim is the first action times 2.5, held within [-1.5, 1.5]: nothing beyond
  1.5 in magnitude can be reached."""

  observation_size, action_size = 1, 1

  def reset(self, key):
    return State(data=None, obs=jnp.zeros(1), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(obs=jnp.clip(2.5 * action[:1], -1.5, 1.5))


def _run(sign):
  """GCRL (the latent is the goal itself, U(-2.5, 2.5)) with a policy that acts at ``sign`` times
  its latent over 2.5: true to its latent for +1, the mirror image for -1."""
  def policy(params, obs, z, *, key, deterministic):
    return sign * z / 2.5
  return SimpleNamespace(env=envs.episode(_Limited(), 8), policy=policy,
                         objective=objectives.gcrl(obs_indices=(0,)))


def _expected_reach_lgr(goals):
  return float(np.mean(np.abs(goals - np.clip(goals, -1.5, 1.5))))


def test_a_true_policy_loses_only_the_goals_beyond_its_reach_and_a_mirrored_one_its_inference():
  params = SimpleNamespace(objective=None)
  goals = np.asarray(metrics.lgr_goals(_run(1).objective))[:, 0]
  assert np.abs(goals).max() > 1.5  # some goals lie beyond reach, or the test tells nothing
  floor = _expected_reach_lgr(goals)
  true = jax.jit(lambda k: goal_reaching.seed_goals(_run(1), params, k, goals[:, None], 2, 64,
                                                     False))(
      jax.random.PRNGKey(0))
  np.testing.assert_allclose(true["lgr"], floor, atol=1e-5)
  # 64 draws of the prior's latents come within about 0.1 of every reachable state
  np.testing.assert_allclose(true["best_lgr"], floor, atol=0.05)
  np.testing.assert_allclose(true["reach_lgr"], floor, atol=0.05)
  assert abs(float(true["inference_excess"])) < 0.05
  np.testing.assert_allclose(true["reach_low"], [-1.5], atol=1e-5)
  np.testing.assert_allclose(true["reach_high"], [1.5], atol=1e-5)
  np.testing.assert_allclose(true["reached_mean"][:, 0], np.clip(goals, -1.5, 1.5), atol=1e-5)
  # the protocol's own evaluator reads the same LGR from these goals and latents
  evaluator = metrics.mimax_evaluator(_run(1).env, _run(1).objective, num_latents=2,
                                      episodes_per_latent=2, last_steps=4, deterministic=True)
  np.testing.assert_allclose(evaluator(_run(1).policy, params, jax.random.PRNGKey(0))["eval/lgr"],
                             true["lgr"], atol=1e-5)
  mirrored = jax.jit(lambda k: goal_reaching.seed_goals(_run(-1), params, k, goals[:, None], 2,
                                                         64, False))(
      jax.random.PRNGKey(0))
  # the same reach, so the same best; the inferred latents send every goal the wrong way
  np.testing.assert_allclose(mirrored["best_lgr"], true["best_lgr"], atol=0.05)
  expected = np.mean(np.abs(goals + np.clip(goals, -1.5, 1.5)))
  np.testing.assert_allclose(mirrored["lgr"], expected, atol=1e-5)
  np.testing.assert_allclose(mirrored["inference_excess"], expected - floor, atol=0.05)
  # the true policy runs each goal's way, as far as 1.5; the mirrored one the opposite way
  read = lambda out: goal_reaching.following(
      *(np.asarray(out[k]) for k in ("candidates", "candidate_means", "reached_mean")))
  np.testing.assert_allclose(read(true)["farthest"], 1.5, atol=1e-5)
  np.testing.assert_allclose(read(true)["goal_cosine"], 1.0, atol=1e-5)
  np.testing.assert_allclose(read(mirrored)["goal_cosine"], -1.0, atol=1e-5)


def test_plot_draws_from_the_json(tmp_path):
  row = {"goals": [[-3.0], [0.5]], "reached_mean": [[-1.5], [0.5]], "reached_std": [[0.1], [0.2]],
         "candidates": [[-1.0], [0.0], [1.0]], "candidate_means": [[-1.5], [0.0], [1.5]],
         "reach_low": [-1.5], "reach_high": [1.5]}
  result = {"label": "gcrl on a stand-in, 1 seed", "indices": [0], "obs_scale": 5.0,
            "discrete": False, "deterministic": False, "per_seed": {"0": row},
            "summary": {"lgr": [0.75], "best_lgr": [0.75], "reach_lgr": [0.75]}}
  (tmp_path / "goal_reaching.json").write_text(json.dumps(result))
  assert goal_reaching.main([str(tmp_path), "--plot"]) == 0
  assert (tmp_path / "goal_reaching.png").stat().st_size > 10_000


@pytest.mark.parametrize("argv, message", [
    (["--episodes", "0"], "--episodes 0: give 1 or more"),
    (["--candidates", "0"], "--candidates 0: give 1 or more"),
    (["--plot"], "goal_reaching.json is missing; run the analysis first"),
    (["--plot", "--seeds", "0"], "--seeds, --deterministic and --goal-draw choose the analysis"),
    (["--plot", "--goal-draw", "braxlines"], "--goal-draw choose the analysis"),
    ([], "no run directory at"),
])
def test_bad_input_is_named(capsys, tmp_path, argv, message):
  with pytest.raises(SystemExit) as exit_:
    goal_reaching.main([str(tmp_path / "nothing"), *argv])
  assert exit_.value.code == 2 and message in capsys.readouterr().err
