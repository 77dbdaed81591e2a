"""Evaluation helpers on the point mass with hand-written policies whose skills go to known places."""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, metrics, objectives
from tests.conftest import make_env


def point(episode_length: int = 100):
  """The session's point env with ``episode_length``-step episodes (the env owns its episode)."""
  return envs.episode(envs.unwrap(make_env("point")), episode_length)


class Hand(NamedTuple):
  """Parameters of the hand-written policies below; ``objective`` is what evaluators read (gcrl and
  gail learn nothing here: no objective parameters)."""

  gain: float
  noise: float = 0.0
  objective: dict = {}


def go_to(params, obs, z, key=None, deterministic=False):
  """A PD controller that drives the point to position z (it settles within about 40 steps); it
  ignores the evaluation's sampling key."""
  return jnp.clip(params.gain * (z - obs[:, :2]) - 0.5 * obs[:, 2:], -1.0, 1.0)


def noisy_go_to(params, obs, z, key=None, deterministic=False):
  """go_to with uniform action noise of amplitude params.noise unless deterministic."""
  action = go_to(params, obs, z)
  if deterministic:
    return action
  return jnp.clip(action + params.noise * jax.random.uniform(key, action.shape, minval=-1.0),
                  -1.0, 1.0)


def test_mimax_helper_on_skills_that_reach_their_goals():
  env = point(100)
  obj = objectives.gcrl(obs_indices="pos_xy", env=env, obs_scale=5.0)
  out = metrics.evaluate_mimax(env, obj, Hand(gain=2.0), jax.random.PRNGKey(0),
                               policy=go_to, num_latents=10, episodes_per_latent=2,
                               last_steps=20, bins=1001)
  # 10 skills (z ~ U(-2.5, 2.5)^2), each settled at its own z: per dimension every skill fills
  # its own bin, so H(s) = log 10, H(s|z) = 0 and MI = log 10 = 2.302585.
  np.testing.assert_allclose(out["eval/mi"], math.log(10), rtol=1e-5)
  np.testing.assert_allclose(out["eval/mi_1d/0"], math.log(10), rtol=1e-5)
  np.testing.assert_allclose(out["eval/conditional_entropy"], 0.0, atol=1e-6)
  # LGR: for gcrl the latent inferred from a goal is the goal itself, which the controller reaches.
  assert out["eval/lgr"] < 1e-3
  # With a controller too weak to arrive (gain 0: the point never moves from the origin) the LGR
  # is the mean RMS distance of the 10 goals ~ U(-5, 5)^2 from the origin, and MI is 0: the
  # paper's goals by default, the other draw where asked.
  for draw, goals in _goals_from_key_0((10, 2)).items():
    still = metrics.evaluate_mimax(env, obj, Hand(gain=0.0), jax.random.PRNGKey(0),
                                   policy=go_to, num_latents=10, episodes_per_latent=2,
                                   last_steps=20, bins=1001,
                                   **({} if draw == "braxlines" else {"goal_draw": draw}))
    np.testing.assert_allclose(still["eval/lgr"], np.mean(np.sqrt(np.mean(goals**2, -1))),
                               rtol=1e-4)
    np.testing.assert_allclose(still["eval/mi"], 0.0, atol=1e-6)


def _goals_from_key_0(shape) -> dict:
  """U(-5, 5) draws from PRNGKey(0) with the random bits of the JAX Braxlines ran on (threefry as
  it was before JAX 0.5) and with those of today's default (partitionable threefry)."""
  out = {}
  for draw, partitionable in (("braxlines", False), ("partitionable", True)):
    with jax.threefry_partitionable(partitionable):
      out[draw] = np.asarray(jax.random.uniform(jax.random.PRNGKey(0), shape, minval=-5.0,
                                                maxval=5.0))
  return out


def test_lgr_goals_are_the_papers_whatever_this_jaxs_default():
  obj = objectives.gcrl(obs_indices="pos_xy", env=point(), obs_scale=5.0)
  expected = _goals_from_key_0((10, 2))
  assert not np.allclose(expected["braxlines"], expected["partitionable"])  # the same key
  default = jax.config.jax_threefry_partitionable
  for partitionable in (False, True):  # the process's own setting changes nothing
    with jax.threefry_partitionable(partitionable):
      np.testing.assert_array_equal(metrics.lgr_goals(obj), expected["braxlines"])
      for draw in metrics.LGR_GOAL_DRAWS:
        np.testing.assert_array_equal(metrics.lgr_goals(obj, draw=draw), expected[draw])
  assert jax.config.jax_threefry_partitionable == default  # and is left as it was
  with pytest.raises(ValueError, match="draw 'numpy': valid are braxlines, partitionable"):
    metrics.lgr_goals(obj, draw="numpy")


def test_a_jax_without_the_old_random_bits_names_the_one_draw_it_can_make(monkeypatch):
  obj = objectives.gcrl(obs_indices="pos_xy", env=point(), obs_scale=5.0)
  expected = _goals_from_key_0((10, 2))["partitionable"]
  monkeypatch.delattr(jax, "threefry_partitionable")
  with pytest.raises(ValueError, match="no threefry_partitionable setting to draw the paper's "
                                       "goals with; valid here is draw='partitionable' alone"):
    metrics.lgr_goals(obj)
  np.testing.assert_array_equal(metrics.lgr_goals(obj, draw="partitionable"), expected)


def test_lgr_goals_are_what_braxlines_own_call_drew_on_the_jax_it_ran_on():
  # Braxlines (vgcrl/train.py): tfd.Uniform(-obs_scale, obs_scale).sample(10, PRNGKey(0)), with
  # obs_scale a vector over the evaluated dims, on a JAX of 2021 (threefry before JAX 0.5).
  tfd = pytest.importorskip("tensorflow_probability.substrates.jax").distributions
  obj = objectives.gcrl(obs_indices="pos_xy", env=point(), obs_scale=5.0)
  scale = np.full(2, 5.0, np.float32)
  with jax.threefry_partitionable(False):
    theirs = tfd.Uniform(low=-scale, high=scale).sample(seed=jax.random.PRNGKey(0),
                                                        sample_shape=(10,))
  np.testing.assert_allclose(metrics.lgr_goals(obj), theirs, atol=1e-6)


def test_draws_latents_says_which_presets_the_evaluator_samples_latents_for():
  # A prior drawn from gives other latents under another key; fixed skills (every one-hot) and a
  # fixed goal are the same under any key; an objective without a prior draws nothing.
  drawn = set()
  for name in objectives.list_objectives():
    options = {"obs_indices": (0, 1)} if "obs_indices" in objectives.options_of(name) else {}
    objective = objectives.make(name, **options)
    if not isinstance(objective.spec, objectives.MimaxSpec):
      assert not metrics.draws_latents(objective), name
      continue
    first, second = (metrics.latents_for_evaluation(objective, jax.random.PRNGKey(seed), 3)
                     for seed in (0, 1))
    assert metrics.draws_latents(objective) == (not np.array_equal(first, second)), name
    if metrics.draws_latents(objective):
      drawn.add(name)
  assert drawn == {"cdiayn", "gcrl"}


def test_dmin_helper_matches_a_direct_energy_distance():
  env = point(100)
  obj = objectives.gail(obs_indices="pos_xy", env=env, obs_scale=8.0)  # modes (+-4, 0)
  params = Hand(gain=2.0)
  policy = lambda params, obs, z, **_: go_to(params, obs, jnp.array([4.0, 0.0]))
  out = metrics.evaluate_dmin(env, obj, params, jax.random.PRNGKey(0), policy=policy,
                              num_episodes=2, last_steps=20, every=1)
  # Settled at (4, 0): X is 40 copies of (4, 0), so E||X - X'|| = 0 and
  # ED = 2 mean_j ||(4, 0) - y_j|| - mean_jk ||y_j - y_k||.
  y = np.asarray(obj.spec.target.samples, np.float64)
  expected = (2 * np.linalg.norm(y - [4.0, 0.0], axis=-1).mean()
              - np.linalg.norm(y[:, None] - y[None], axis=-1).mean())
  np.testing.assert_allclose(out["eval/energy_distance"], expected, rtol=1e-3)
  # Every sample sits on mode 0, (4, 0): the policy covers one of the target's two modes.
  assert out["eval/mode_share/0"] == 1.0 and out["eval/mode_share/1"] == 0.0
  assert out["eval/episode_mode_share/0"] == 1.0
  assert out["eval/mode_balance"] == 0.0  # committed to one mode


def test_mode_shares_tell_episodes_that_pick_a_mode_from_episodes_that_visit_both():
  means = jnp.array([[4.0, 0.0], [-4.0, 0.0]])
  plus, minus = [3.5, 0.3], [-4.2, -0.1]
  x = jnp.array([[plus] * 4,                   # episode 0 stays at +4
                 [minus] * 4,                  # episode 1 at -4
                 [plus, plus, plus, minus]])   # episode 2 goes to both, mostly +4
  out = metrics.mode_shares(x, means)
  np.testing.assert_allclose(out["eval/mode_share/0"], (1 + 0 + 0.75) / 3, rtol=1e-6)
  np.testing.assert_allclose(out["eval/mode_share/1"], (0 + 1 + 0.25) / 3, rtol=1e-6)
  np.testing.assert_allclose(out["eval/episode_mode_share/0"], 2 / 3, rtol=1e-6)
  np.testing.assert_allclose(out["eval/episode_mode_share/1"], 1 / 3, rtol=1e-6)
  # the least sample share, 1.25 / 3, times the two modes
  np.testing.assert_allclose(out["eval/mode_balance"], 2 * 1.25 / 3, rtol=1e-6)


def test_mode_balance_is_one_for_an_even_split_and_zero_for_a_mode_never_visited():
  np.testing.assert_allclose(metrics.mode_balance(jnp.array([0.5, 0.5])), 1.0)
  np.testing.assert_allclose(metrics.mode_balance(jnp.array([0.6, 0.4])), 0.8, rtol=1e-6)
  np.testing.assert_allclose(metrics.mode_balance(jnp.array([1.0, 0.0])), 0.0)
  # K modes, per row of a batch: 3 x the least share
  np.testing.assert_allclose(metrics.mode_balance(jnp.array([[0.2, 0.3, 0.5], [1 / 3] * 3])),
                             [0.6, 1.0], rtol=1e-6)


def test_evaluation_samples_actions_unless_deterministic():
  # Braxlines evaluates the policy's sampled actions. A policy whose samples carry noise spreads
  # each skill over several bins (H(s|z) > 0, lower MI); its mean action reproduces the exact
  # log 10 of the noiseless skills. Fresh noise every step (not one key for the whole episode)
  # keeps the settled point moving.
  env = point(100)
  obj = objectives.gcrl(obs_indices="pos_xy", env=env, obs_scale=5.0)
  params = Hand(gain=2.0, noise=1.0)
  settings = dict(policy=noisy_go_to, num_latents=10, episodes_per_latent=2, last_steps=20,
                  bins=1001)
  sampled = metrics.evaluate_mimax(env, obj, params, jax.random.PRNGKey(0), **settings)
  mean = metrics.evaluate_mimax(env, obj, params, jax.random.PRNGKey(0), deterministic=True,
                                **settings)
  np.testing.assert_allclose(mean["eval/mi"], math.log(10), rtol=1e-5)
  assert sampled["eval/conditional_entropy"] > 1.0
  assert sampled["eval/mi"] < mean["eval/mi"] - 0.1
  states = metrics.rollout(env, noisy_go_to, params, jnp.eye(2), jax.random.PRNGKey(1),
                           episodes_per_latent=1)
  late = np.asarray(states[:, 0, -20:, :2])
  assert (np.abs(np.diff(late, axis=1)).max(axis=(1, 2)) > 1e-3).all()


class _Falls:
  """A stand-in env whose observation counts steps and which terminates at step 3."""

  observation_size, action_size = 1, 1

  def reset(self, key):
    from blx.envs.env import State
    return State(data=jnp.zeros(()), obs=jnp.zeros(1), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    t = state.data + 1.0
    return state.replace(data=t, obs=t[None], done=(t >= 3.0).astype(jnp.float32))


def test_rollout_goes_on_after_termination_as_braxlines():
  # Braxlines' evaluation envs do not auto-reset and keep stepping a terminated episode: the
  # states after the fall are recorded as they come, not frozen at the fall.
  still = lambda params, obs, z, **_: jnp.zeros((obs.shape[0], 1))
  states = metrics.rollout(envs.episode(_Falls(), 6), still, {}, jnp.zeros((1, 0)),
                           jax.random.PRNGKey(0), episodes_per_latent=2, conditions_policy=False)
  np.testing.assert_array_equal(states[0, :, :, 0], [[1, 2, 3, 4, 5, 6]] * 2)
  # Evaluation runs whole episodes of the env as given: one that resets itself is refused.
  with pytest.raises(ValueError, match="rollout: the env already resets itself"):
    metrics.rollout(envs.auto_reset(envs.episode(_Falls(), 6)), still, {}, jnp.zeros((1, 0)),
                    jax.random.PRNGKey(0), episodes_per_latent=2, conditions_policy=False)


def test_alive_share_counts_the_scored_states_before_each_episodes_end():
  done = jnp.array([[0, 0, 1, 1, 1, 1],    # ends at step 2: steps 0-2 count, 3-5 come after
                    [0, 0, 0, 0, 0, 0]])   # never ends
  # The last 4 steps (2..5): episode 0 has 1 of 4 before its end, episode 1 all 4: 5 / 8.
  np.testing.assert_allclose(metrics.alive_share(done, 4), 5 / 8)
  # Every 2nd of them (steps 2 and 4): 1 of 2 and 2 of 2.
  np.testing.assert_allclose(metrics.alive_share(done, 4, 2), 3 / 4)
  np.testing.assert_allclose(metrics.alive_share(jnp.zeros((3, 5)), 5), 1.0)


def test_both_evaluators_say_how_many_scored_states_came_after_a_fall():
  # _Falls ends every episode at its third step and steps on (as Braxlines' evaluation does): of
  # the last 4 of 6 steps only the first (the step that ended the episode) is before the end.
  env = envs.episode(_Falls(), 6)
  still = lambda params, obs, z=None, **_: jnp.zeros((obs.shape[0], 1))
  gail = objectives.gail(obs_indices=(0,), obs_scale=8.0)
  out = metrics.evaluate_dmin(env, gail, Hand(gain=0.0), jax.random.PRNGKey(0), policy=still,
                              num_episodes=2, last_steps=4, every=1)
  np.testing.assert_allclose(out["eval/alive_share"], 0.25)
  # Every episode is down at once from step 3, so Braxlines' rollout keeps s_0 .. s_2 (obs 0, 1,
  # 2) and scores them all (fewer than 4): not the fallen states 3 .. 6 of the fixed window.
  target = jnp.asarray(gail.spec.target.samples)[:, :1]
  np.testing.assert_allclose(out["eval/energy_distance_braxlines"],
                             metrics.energy_distance(jnp.array([0.0, 1, 2, 0, 1, 2]), target),
                             rtol=1e-5)
  np.testing.assert_allclose(out["eval/energy_distance"],
                             metrics.energy_distance(jnp.array([3.0, 4, 5, 6, 3, 4, 5, 6]), target),
                             rtol=1e-5)
  gcrl = objectives.gcrl(obs_indices=(0,), obs_scale=5.0)
  out = metrics.evaluate_mimax(env, gcrl, Hand(gain=0.0), jax.random.PRNGKey(0), policy=still,
                               num_latents=3, episodes_per_latent=2, last_steps=4, num_goals=2)
  np.testing.assert_allclose(out["eval/alive_share"], 0.25)
  # The MI diagnostic of the states before the falls sees one state per episode (obs 3, the
  # same for every latent): H(s) = 0 there, while the protocol's H(s) sees obs 3, 4, 5 and 6,
  # a quarter each (6 is outside [-5, 5]: counted, in no bin), -3/4 log 1/4.
  np.testing.assert_allclose(out["eval/entropy_alive"], 0.0, atol=1e-6)
  np.testing.assert_allclose(out["eval/mi_alive"], 0.0, atol=1e-6)
  np.testing.assert_allclose(out["eval/entropy"], 0.75 * np.log(4), rtol=1e-5)
  # Braxlines' window: s_0 .. s_2 (obs 0, 1, 2), a third each.
  np.testing.assert_allclose(out["eval/entropy_braxlines"], np.log(3), rtol=1e-5)
  np.testing.assert_allclose(out["eval/mi_braxlines"], 0.0, atol=1e-6)
  # The point mass never ends an episode early: every scored state counts.
  env = point(50)
  out = metrics.evaluate_mimax(env, objectives.gcrl(obs_indices="pos_xy", env=env, obs_scale=5.0),
                               Hand(gain=2.0), jax.random.PRNGKey(0), policy=go_to,
                               num_latents=2, episodes_per_latent=1, last_steps=10)
  assert out["eval/alive_share"] == 1.0
  np.testing.assert_allclose(out["eval/mi_alive"], out["eval/mi"], rtol=1e-6)
  np.testing.assert_allclose(out["eval/entropy_alive"], out["eval/entropy"], rtol=1e-6)
  # Nor is every episode done before the step limit: Braxlines scores the same last 10 states,
  # one step earlier (s_40 .. s_49 against s_41 .. s_50); the skills have settled by then.
  np.testing.assert_allclose(out["eval/mi_braxlines"], out["eval/mi"], rtol=1e-3)
  np.testing.assert_allclose(out["eval/entropy_braxlines"], out["eval/entropy"], rtol=1e-3)


def test_a_new_family_plugs_in_through_one_registration(monkeypatch):
  # A toy objective family: its own spec type, one registration, and runs find its evaluator and
  # table columns without any change in training, runs, sweeps, plots or the CLI.
  from typing import NamedTuple

  from blx.experiments import runs
  from blx.metrics import families

  class ToySpec(NamedTuple):
    scale: float

  toy = objectives.task()._replace(name="toy", spec=ToySpec(2.0))
  with pytest.raises(ValueError, match="no evaluation is registered for its spec type ToySpec"):
    metrics.family_of(toy)
  evaluator = lambda policy, params, key: {"eval/toy": jnp.asarray(2.0)}
  family = metrics.Family(name="toy", table=(("toy", "eval/toy", 1.0),),
                          make_evaluator=lambda env, objective, **settings: evaluator)
  monkeypatch.setattr(families, "_FAMILIES", dict(families._FAMILIES))
  metrics.register_family(ToySpec, family)
  assert metrics.family_of(toy) is family
  env = make_env("point")
  assert runs.evaluator_for(env, toy) is evaluator
  with pytest.raises(ValueError, match="already registered"):
    metrics.register_family(ToySpec, family)
  with pytest.raises(ValueError, match="plot='bars' is not valid"):
    metrics.register_family(str, family._replace(plot="bars"))


def test_braxlines_window_moves_before_the_ends_when_every_episode_ends_early():
  # 20 steps; per-step done flags of s_1 .. s_20. Episode 0 falls at step 5 and stays down;
  # episode 1 falls at step 7, gets up at step 9 and falls again from step 12. Every episode is
  # down at once first at step 7 (E = 7), so Braxlines keeps s_0 .. s_6.
  done = np.zeros((2, 20))
  done[0, 4:] = 1.0
  done[1, 6:8] = 1.0
  done[1, 11:] = 1.0
  window = lambda last, every: np.flatnonzero(metrics.braxlines_window(jnp.asarray(done), last,
                                                                       every))
  assert int(metrics.braxlines_end(jnp.asarray(done))) == 7
  np.testing.assert_array_equal(window(500, 1), np.arange(7))
  np.testing.assert_array_equal(window(4, 1), [3, 4, 5, 6])
  np.testing.assert_array_equal(window(6, 2), [1, 3, 5])
  # No early end: only the step limit sets every flag, at s_20, so s_0 .. s_19 are kept and the
  # last 5 scored: s_15 .. s_19.
  done[:, :] = 0.0
  done[:, 19] = 1.0
  np.testing.assert_array_equal(window(5, 1), np.arange(15, 20))
  np.testing.assert_array_equal(window(10, 5), [10, 15])


def test_braxlines_mutual_information_is_the_mi_of_the_kept_window_alone():
  # 2 skills x 2 episodes x 8 steps. Every episode is down from step 3 (E = 3), so with 6 scored
  # steps Braxlines keeps s_0 .. s_2. Before the fall skill 0 sits at -1 and skill 1 at +1 (MI
  # log 2); from s_3 on both lie at 0 and would mix them.
  states = np.zeros((2, 2, 8, 1), np.float32)
  states[0, :, :3] = -1.0
  states[1, :, :3] = 1.0
  done = np.zeros((2, 2, 8), np.float32)
  done[..., 2:] = 1.0
  out = metrics.braxlines_mutual_information(jnp.asarray(states), jnp.asarray(done), 6, bins=20,
                                             value_range=(-2.0, 2.0))
  kept = metrics.mutual_information(
      jnp.asarray(states[:, :, :3].reshape(-1, 1)), jnp.repeat(jnp.arange(2), 6), bins=20,
      value_range=(-2.0, 2.0), num_labels=2)
  np.testing.assert_allclose(out["mi"], kept["mi"], rtol=1e-6)
  np.testing.assert_allclose(out["entropy"], kept["entropy"], rtol=1e-6)
  np.testing.assert_allclose(out["mi"], math.log(2), rtol=1e-5)
