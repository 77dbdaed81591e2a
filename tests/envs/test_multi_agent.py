"""Multi-agent scenes: claiming reward terms and actuators, per-agent rewards, action routing, and
the registered follow, chase and sumo scenes (their physics is checked with every registered env in
``test_registered_envs``)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs


def two_points(agent_groups=None, **edge_terms):
  """Points a at (0, 0) and b at (3, 0), undamped (they keep their velocity) unless driven."""
  point = lambda pos, terms: dict(component="point", component_params=dict(damping=0.0), pos=pos,
                                  reward_fns=terms)
  desc = dict(
      components=dict(
          a=point((0.0, 0.0, 0.0), dict(goal=dict(reward_type="root_goal", sdcomp="pos",
                                                  indices=(0, 1), target_goal=(1.0, 0.0)))),
          b=point((3.0, 0.0, 0.0), dict(speed=dict(reward_type="norm", sdcomp="vel",
                                                   indices=(0, 1), scale=-1.0)))),
      edges=dict(a__b=dict(reward_fns=dict(
          dist=dict(reward_type="root_dist", offset=5.0),
          b_from_origin=dict(reward_type="norm", of="b", sdcomp="pos", indices=(0, 1)),
          **edge_terms))),
      global_options=dict(timestep=0.05, substeps=2))
  desc["agent_groups"] = agent_groups if agent_groups is not None else dict(
      a=dict(reward_agents=("a",), reward_names=("a__b/b_from_origin",)),
      b=dict(reward_agents=("b",), reward_names=("a__b/dist",)))
  return desc


@functools.lru_cache(maxsize=None)
def scene():
  env = envs.create(desc=two_points(), episode_length=None)
  return env, jax.jit(env.reset), jax.jit(env.step)


def test_rewards_are_per_agent_and_match_hand_computed_values():
  env, reset, step = scene()
  assert env.agent_names == ("a", "b") and env.num_agents == 2
  state = step(reset(jax.random.PRNGKey(0)), jnp.zeros(env.action_size))
  # Nothing moves: a is 1 m from its goal (1, 0), and b is 3 m from the origin; b's speed is 0 and
  # the two are 3 m apart (root_dist offset 5).
  np.testing.assert_allclose(state.reward, [-1.0 - 3.0, 5.0 - 3.0 + 0.0], atol=1e-5)
  m = {k: float(v) for k, v in state.metrics.items()}
  assert m["reward/a/a/goal"] == pytest.approx(-1.0, abs=1e-5)
  assert m["reward/a/a__b/b_from_origin"] == pytest.approx(-3.0, abs=1e-5)
  assert m["reward/b/a__b/dist"] == pytest.approx(2.0, abs=1e-5)
  assert m["score/b/a__b/dist"] == pytest.approx(-3.0, abs=1e-5)  # the score drops the offset
  assert m["score/a"] == pytest.approx(-4.0, abs=1e-5)
  assert m["score/b"] == pytest.approx(-3.0, abs=1e-5)
  assert m["score"] == pytest.approx(-7.0, abs=1e-5)
  assert set(m) == set(reset(jax.random.PRNGKey(0)).metrics)  # reset names the same metrics


def test_each_agents_action_moves_only_that_agent():
  env, reset, step = scene()
  idx = env.agent_action_indices
  assert sorted(np.concatenate(list(idx.values())).tolist()) == list(range(env.action_size))
  layout = env.obs_layout
  for mover, still in (("a", "b"), ("b", "a")):
    state = reset(jax.random.PRNGKey(0))
    start = np.asarray(state.obs)
    action = jnp.zeros(env.action_size).at[idx[mover]].set(1.0)
    for _ in range(5):
      state = step(state, action)
    obs = np.asarray(state.obs)
    moved = lambda agent: np.abs(obs[layout[f"{agent}/root_pos[0,1]"]]
                                 - start[layout[f"{agent}/root_pos[0,1]"]]).max()
    assert moved(mover) > 0.1, mover
    assert moved(still) == 0.0, still


def test_direction_rewards_moving_against_the_opponents_velocity():
  # a moves +x at 1 m/s towards b, which moves -x at 2 m/s: r = max(0, v_a . -v_b/|v_b|) = 1; if
  # b moves +x instead, a runs along with it and r = 0. ``of`` picks the mover.
  desc = two_points(
      dict(a=dict(reward_agents=("a",), reward_names=("a__b/b_from_origin", "a__b/a_at_b")),
           b=dict(reward_agents=("b",), reward_names=("a__b/dist", "a__b/b_at_a"))),
      a_at_b=dict(reward_type="direction"), b_at_a=dict(reward_type="direction", of="b"))
  env = envs.create(desc=desc, episode_length=None)
  step = jax.jit(env.step)
  state = jax.jit(env.reset)(jax.random.PRNGKey(0))
  for vb, expect_a, expect_b in ((-2.0, 1.0, 2.0), (2.0, 0.0, 0.0)):
    qvel = jnp.asarray([1.0, 0.0, vb, 0.0])
    moving = state.replace(data=state.data.replace(qvel=qvel))
    m = step(moving, jnp.zeros(env.action_size)).metrics
    assert float(m["reward/a/a__b/a_at_b"]) == pytest.approx(expect_a, abs=1e-5), vb
    assert float(m["reward/b/a__b/b_at_a"]) == pytest.approx(expect_b, abs=1e-5), vb


def test_a_single_agent_scene_is_unchanged():
  env = envs.create("point_goal")
  assert env.agent_names == () and env.num_agents == 1 and env.agent_action_indices == {}
  state = jax.jit(env.step)(jax.jit(env.reset)(jax.random.PRNGKey(0)), jnp.zeros(env.action_size))
  assert state.reward.shape == ()
  assert "reward/agent1/goal" in state.metrics


@pytest.mark.parametrize("groups, message", [
    (dict(a=dict(reward_agents=("a",)), b=dict(reward_agents=("b",))),
     r"reward terms \['a__b/dist', 'a__b/b_from_origin'\] are claimed by no agent"),
    (dict(a=dict(reward_agents=("a",), reward_names=("a__b/dist", "a__b/b_from_origin")),
          b=dict(reward_agents=("b",), reward_names=("a__b/dist",))),
     r"claimed by several agents: \{'a__b/dist': \['a', 'b'\]\}"),
    (dict(a=dict(reward_names=("a/nope",))),
     r"agent_groups.a.reward_names: unknown reward term\(s\) \['a/nope'\]; valid reward terms are"),
    (dict(a=dict(reward_agents=("c",))),
     r"agent_groups.a.reward_agents: unknown component\(s\) \['c'\]; valid components are"),
    (dict(a=dict(reward_agents=("a", "b"), reward_names=("a__b/dist", "a__b/b_from_origin"))),
     r"the actuators of \['b'\] are driven by no agent"),
    (dict(a=dict(reward_agents=("a", "b"), reward_names=("a__b/dist", "a__b/b_from_origin")),
          b=dict(action_agents=("a", "b"))),
     r"components driven by several agents: \{'a': \['a', 'b'\]\}"),
    (dict(a=dict(reward_agents=("a", "b"), reward_names=("a__b/dist", "a__b/b_from_origin")),
          team=dict()),
     r"agent_groups.team: no component is named 'team', so give 'action_agents'"),
    (dict(a=dict(reward_agents="a")), r"agent_groups.a.reward_agents: expected a list of names"),
    (dict(a=dict(rewards=("a",))), r"agent_groups.a: unknown key\(s\) \['rewards'\]"),
    ({}, r"desc.agent_groups: expected a non-empty dict"),
])
def test_bad_agent_groups_are_named(groups, message):
  with pytest.raises(ValueError, match=message):
    envs.create(desc=two_points(groups))


def test_of_must_name_one_of_the_edges_components():
  desc = two_points()
  desc["edges"]["a__b"]["reward_fns"]["b_from_origin"]["of"] = "c"
  with pytest.raises(ValueError, match=r"b_from_origin.of: 'c' is not one of the edge's "
                                       r"components; .*here \['a', 'b'\]"):
    envs.create(desc=desc)
  desc = two_points()
  desc["components"]["a"]["reward_fns"]["goal"]["of"] = "a"
  with pytest.raises(ValueError, match=r"goal.of: 'a' is not one of the edge's components; 'of' is "
                                       r"for edge terms"):
    envs.create(desc=desc)


def test_registered_scenes_claim_every_term_as_the_original():
  # Agents on a circle of radius 2, every pair observed; the original's terms, offsets and bonuses.
  follow = envs.unwrap(envs.create("follow", main_agent="point", other_agent="point",
                                   num_agents=3))
  assert follow.agent_names == ("agent0", "agent1", "agent2")
  assert [k for k in follow.obs_layout if "root_vec" in k] == [
      "agent0__agent1/root_vec_pos[0,1]", "agent0__agent2/root_vec_pos[0,1]",
      "agent1__agent2/root_vec_pos[0,1]"]
  owners = dict(zip(follow.reward_terms, (follow.agent_names[i] for i in follow.agents.term_agent)))
  assert owners == {"agent0/goal": "agent0", "agent0__agent1/dist": "agent1",
                    "agent0__agent2/dist": "agent2"}
  desc = envs.get_desc("follow", leader_vel=2.0)
  assert desc["components"]["agent0"]["reward_fns"]["goal"]["offset"] == 4.0
  assert desc["edges"]["agent0__agent1"]["reward_fns"]["dist"]["max_dist"] == 20.0
  assert np.allclose(desc["components"]["agent1"]["pos"], (-2.0, 0.0, 0.0))

  chase = envs.get_desc("chase")
  assert chase["agent_groups"]["agent0"]["reward_names"] == (
      "agent0__agent1/escape", "agent0/run")
  assert chase["agent_groups"]["agent1"]["reward_names"] == ("agent0__agent1/chase", "agent1/run")
  assert chase["edges"]["agent0__agent1"]["reward_fns"]["chase"]["done_bonus"] == 20_000.0

  sumo = envs.unwrap(envs.create("sumo", main_agent="point", other_agent="point", ring_size=2.5))
  owners = dict(zip(sumo.reward_terms, (sumo.agent_names[i] for i in sumo.agents.term_agent)))
  assert sorted(t for t, a in owners.items() if a == "agent1") == [
      "agent0__agent1/komu_lose_penalty", "agent0__agent1/komu_move_to_yoko",
      "agent0__agent1/komu_win_bonus", "agent1/control_penalty", "agent1/draw_penalty"]
  assert sum(n.startswith("ring") for n in sumo.desc["components"]) == 20
  # The ring is drawn only: frozen, without contacts, unobserved.
  assert not any(k.startswith("ring") for k in sumo.obs_layout)
  assert "ring0/" not in "".join(l for l in sumo.xml.splitlines() if "<pair" in l)


def test_sumo_pays_the_win_bonus_and_ends_when_an_agent_leaves_the_ring():
  env = envs.create("sumo", main_agent="point", other_agent="point", ring_size=2.5,
                    episode_length=None)
  idx = env.agent_action_indices
  state = jax.jit(env.reset)(jax.random.PRNGKey(0))
  step = jax.jit(env.step)
  # agent1 starts at (-2, 0) and walks out along -x; agent0 stands still.
  action = jnp.zeros(env.action_size).at[idx["agent1"][0]].set(-1.0)
  for t in range(30):
    state = step(state, action)
    if state.done:
      break
  m = {k: float(v) for k, v in state.metrics.items()}
  assert state.done and t < 29
  pos = np.asarray(state.obs[env.obs_layout["agent1/root_pos[0,1]"]])
  assert np.linalg.norm(pos) > 2.5
  assert m["reward/agent0/agent0__agent1/yoko_win_bonus"] == pytest.approx(
      -np.exp(-np.linalg.norm(pos)) + 1.0, abs=1e-4)
  assert m["reward/agent1/agent0__agent1/komu_lose_penalty"] == pytest.approx(
      np.exp(-np.linalg.norm(pos)) - 1.0, abs=1e-4)


def test_bad_scene_parameters_are_named():
  with pytest.raises(ValueError, match=r"chase: num_agents must be an int in 2..10, got 1"):
    envs.create("chase", num_agents=1)
  with pytest.raises(ValueError, match=r"sumo: ring_size must be a positive number, got -1"):
    envs.create("sumo", ring_size=-1.0)
  with pytest.raises(ValueError, match=r"follow: init_r must be a positive number"):
    envs.create("follow", init_r=0.0)


@pytest.mark.parametrize("name", ["follow", "chase", "sumo"])
def test_agent_collide_chooses_which_colliders_of_two_agents_meet(name):
  import mujoco

  def agent_pairs(env):
    m = envs.unwrap(env).mj_model
    names = [(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(a)),
              mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(b)))
             for a, b in zip(m.pair_geom1, m.pair_geom2)]
    return {p for p in names if {p[0].split("/")[0], p[1].split("/")[0]} == {"agent0", "agent1"}}

  full = agent_pairs(envs.create(name))  # the original's: each ant's torso and four feet
  assert len(full) == 25
  (root,) = agent_pairs(envs.create(name, agent_collide="root"))
  assert set(root) == {"agent0/torso_geom", "agent1/torso_geom"}
  assert agent_pairs(envs.create(name, agent_collide="none")) == set()
  with pytest.raises(ValueError, match=r"agent_collide='all'; valid values are \['full', 'root', "
                                       r"'none'\]"):
    envs.create(name, agent_collide="all")
