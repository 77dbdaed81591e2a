"""The composer: the paper's appendix example, layouts, named indices, reward terms, wrappers."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs
from tests.conftest import make_env, step_fn

# The Ant Push desc exactly as written in the Braxlines paper's appendix.
APPENDIX_DESC = dict(
    components=dict(
        agent1=dict(component="pro_ant", component_params=dict(num_legs=6)),
        cap1=dict(
            component="singleton",
            component_params=dict(size=0.5),
            pos=(1, 0, 0),
            reward_fns=dict(goal=dict(reward_type="root_goal", sdcomp="vel",
                                      target_goal=(4, 0, 0))),
        ),
    ),
    edges=dict(
        agent1__cap1=dict(
            extra_observers=[dict(observer_type="root_vec")],
            reward_fns=dict(dist=dict(reward_type="root_dist")),
        ),
    ),
)


def test_singleton_has_braxlines_mass_and_unit_inertia():
  # Braxlines' singleton: mass radius**3 and inertia 1 I_3 (Ant Push's ball: 0.125 kg, 80 times a
  # solid 0.5 m sphere's 0.0125), so a push turns it slowly.
  import mujoco
  m = envs.create("ant_push").mj_model
  ball = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "cap1/object")
  assert float(m.body_mass[ball]) == pytest.approx(0.125)
  np.testing.assert_allclose(m.body_inertia[ball], 1.0)
  big = envs.create("ant_on_ball").mj_model
  ball = mujoco.mj_name2id(big, mujoco.mjtObj.mjOBJ_BODY, "ball/object")
  assert float(big.body_mass[ball]) == pytest.approx(27.0)
  np.testing.assert_allclose(big.body_inertia[ball], 1.0)


def test_appendix_ant_push_example():
  env = envs.create(desc=APPENDIX_DESC)
  assert env.action_size == 12  # 6 legs x (hip, knee)
  # pro_ant root_z_joints: 1 + 4 + 12 + 3 + 3 + 12 = 35, and its contact dv, dw of 13 bodies (torso
  # and 12 leg links): 78; singleton qp: 3 + 4 + 3 + 3; root_vec: 3
  assert env.observation_size == 35 + 78 + 13 + 3
  assert list(env.obs_layout)[-1] == "agent1__cap1/root_vec_pos"
  assert env.reward_terms == ("cap1/goal", "agent1__cap1/dist")
  assert env.obs_indices("vel_xy") == (17, 18)  # 1 + 4 + 12 joint angles

  state = jax.jit(env.reset)(jax.random.PRNGKey(0))
  # Brax's rest pose: ankles at 50 deg, feet on the floor (blx: 1 mm above it), so the torso starts
  # at 0.4 sqrt(2) sin 50 + 0.08 + 0.001 = 0.5143 m; the ball, also 1 mm up, at (1, 0, 0.501):
  # root_vec = (-1, 0, 0.0133).
  np.testing.assert_allclose(state.obs[env.obs_layout["agent1__cap1/root_vec_pos"]],
                             [-1.0, 0.0, 0.4 * np.sqrt(2) * np.sin(np.radians(50)) + 0.08 - 0.5],
                             atol=1e-5)
  state = jax.jit(env.step)(state, jnp.zeros(env.action_size))
  m = state.metrics
  # goal = -||v_ball - (4, 0, 0)||, dist = -||p_torso - p_ball|| (the legs touch the ball at the
  # start, so it moves: read its velocity and the root vector from the observation).
  v_ball = np.asarray(state.obs[env.obs_layout["cap1/root_vel"]], np.float64)
  rel = np.asarray(state.obs[env.obs_layout["agent1__cap1/root_vec_pos"]], np.float64)
  assert float(m["reward/cap1/goal"]) == pytest.approx(-np.linalg.norm(v_ball - [4, 0, 0]), rel=1e-5)
  assert float(m["reward/agent1__cap1/dist"]) == pytest.approx(-np.linalg.norm(rel), rel=1e-5)
  assert np.linalg.norm(rel) == pytest.approx(1.0, abs=0.1)
  assert float(state.reward) == pytest.approx(
      float(m["reward/cap1/goal"] + m["reward/agent1__cap1/dist"]), rel=1e-6)


@pytest.mark.parametrize("name, indices", [("ant", (13, 14)), ("humanoid", (22, 23)),
                                           ("point", (2, 3)), ("ant_push", (13, 14))])
def test_vel_xy_sits_where_the_paper_says(name, indices):
  env = make_env(name)
  assert env.obs_indices("vel_xy") == indices
  assert env.obs_indices("vel") == indices


def test_planar_bodies_offer_vel_x_only():
  env = make_env("halfcheetah")
  assert env.obs_indices("vel_x") == (11,)  # 1 + 4 + 6 joint angles, as the original's table
  with pytest.raises(ValueError, match="planar.*vel_x"):
    env.obs_indices("vel_xy")


def test_obs_indices_read_the_root_velocity():
  env = make_env("ant")
  reset, step = step_fn("ant")
  state = reset(jax.random.PRNGKey(0))
  # Lift the ant into the air and throw it sideways: over one 50 ms step in free fall the xy
  # velocity is unchanged up to the legs' internal motion.
  qpos = state.data.qpos.at[2].set(3.0)
  qvel = state.data.qvel.at[0:2].set(jnp.array([1.5, -0.7]))
  state = state.replace(data=state.data.replace(qpos=qpos, qvel=qvel))
  state = step(state, jnp.zeros(env.action_size))
  vel = np.asarray(state.obs)[list(env.obs_indices("vel_xy"))]
  np.testing.assert_allclose(vel, np.asarray(state.data.qvel[0:2]), rtol=1e-6)
  np.testing.assert_allclose(vel, [1.5, -0.7], atol=0.1)


def test_point_vel_xy_reads_the_slide_velocity():
  env = make_env("point")
  reset, step = step_fn("point")
  state = reset(jax.random.PRNGKey(0))
  state = state.replace(data=state.data.replace(qvel=jnp.array([0.8, -0.4])))
  state = step(state, jnp.zeros(2))
  # Damping 2 N s/m on 1 kg, explicit Euler with two 50 ms substeps: v * (1 - 0.1)^2 = 0.81 v.
  np.testing.assert_allclose(state.obs[np.array(env.obs_indices("vel_xy"))],
                             [0.8 * 0.81, -0.4 * 0.81], rtol=1e-4)


def test_the_actuator_observer_reads_what_the_motors_applied_over_the_last_step():
  observed = lambda *names: envs.create("point", edits={"components.agent1.observers": list(names)})
  env = observed("root_z_joints", "actuator")
  assert env.observation_size == observed("root_z_joints").observation_size + 2
  step = jax.jit(env.step)
  state = env.reset(jax.random.PRNGKey(0))
  np.testing.assert_allclose(state.obs[-2:], 0.0)                  # nothing applied yet
  state = step(state, jnp.array([0.5, -0.25]))
  np.testing.assert_allclose(state.obs[-2:], [0.5, -0.25], atol=1e-6)
  state = step(state, jnp.array([3.0, 0.0]))                       # beyond the control range
  np.testing.assert_allclose(state.obs[-2:], [1.0, 0.0], atol=1e-6)


def test_reset_actions_end_the_reset_with_one_step_of_random_positive_actions():
  # Brax v1's humanoid reset: the default pose, then one control step with actions U[0, 0.5).
  plain = make_env("point")
  pushed = envs.create("point", edits={"global_options.reset_actions": 0.5})
  key = jax.random.PRNGKey(3)
  action = 0.5 * jax.random.uniform(jax.random.fold_in(key, 1), (2,))
  expected = jax.jit(plain.step)(jax.jit(plain.reset)(key), action)
  state = jax.jit(pushed.reset)(key)
  np.testing.assert_allclose(state.obs, expected.obs, rtol=1e-6)
  assert np.all(np.asarray(state.data.qvel) > 0)  # both motors pushed forward
  # A reset is still an episode's start: no reward, not done.
  assert float(state.reward) == 0.0 and float(state.done) == 0.0
  other = jax.jit(pushed.reset)(jax.random.PRNGKey(4))
  assert not np.allclose(other.obs, state.obs)
  np.testing.assert_allclose(jax.jit(plain.reset)(key).data.qvel, 0.0)
  for bad in (-0.1, 1.5, True, float("nan")):
    with pytest.raises(ValueError, match="global_options.reset_actions"):
      envs.create("point", edits={"global_options.reset_actions": bad})


TERMS_DESC = dict(
    components=dict(
        a=dict(component="point", reward_fns=dict(
            goal=dict(reward_type="root_goal", sdcomp="pos", indices=(0, 1), target_goal=(3, 0)),
            speed=dict(reward_type="norm", sdcomp="vel", indices=(0, 1)),
            expspeed=dict(reward_type="exp_norm", sdcomp="vel", indices=(0, 1)),
            ctrl=dict(reward_type="control", scale=-0.5),
            alive=dict(reward_type="constant", value=2.0, offset=1.0, scale=3.0),
            fwd=dict(reward_type="forward", axis=0, exclude_from_score=True),
        )),
        b=dict(component="point", pos=(0, 2, 0)),
    ),
    edges=dict(a__b=dict(reward_fns=dict(
        near=dict(reward_type="root_dist", min_dist=5.0, done_bonus=10.0),
        relvel=dict(reward_type="distance", sdcomp="vel", indices=(0,)),
    ))),
    global_options=dict(timestep=0.05, substeps=2),
)


def test_reward_terms_against_hand_computed_values():
  env = envs.create(desc=TERMS_DESC, episode_length=None)
  state = jax.jit(env.reset)(jax.random.PRNGKey(0))
  qpos = jnp.array([1.0, 1.0, 0.5, -0.5])  # a at (1, 1); b at (0.5, 1.5) (its frame adds y + 2)
  qvel = jnp.array([0.3, 0.4, 0.0, 0.0])
  state = state.replace(data=state.data.replace(qpos=qpos, qvel=qvel))
  action = jnp.array([0.6, -0.8, 0.0, 0.0])
  state = jax.jit(env.step)(state, action)
  m = {k: float(v) for k, v in state.metrics.items()}
  x, y, xb, yb = np.asarray(state.data.qpos, np.float64)
  vx, vy, vxb, _ = np.asarray(state.data.qvel, np.float64)
  yb += 2.0
  assert m["reward/a/goal"] == pytest.approx(-np.hypot(x - 3, y), rel=1e-5)
  assert m["reward/a/speed"] == pytest.approx(-np.hypot(vx, vy), rel=1e-5)
  assert m["reward/a/expspeed"] == pytest.approx(np.exp(-np.hypot(vx, vy)), rel=1e-5)
  # control: -||a_a|| = -||(0.6, -0.8)|| = -1; scale -0.5 -> reward 0.5; score = r * sign = 1.
  assert m["reward/a/ctrl"] == pytest.approx(0.5, rel=1e-6)
  assert m["score/a/ctrl"] == pytest.approx(1.0, rel=1e-6)
  # constant: (2 + 1) * 3 = 9; the score is the raw value 2.
  assert m["reward/a/alive"] == pytest.approx(9.0) and m["score/a/alive"] == pytest.approx(2.0)
  assert m["reward/a/fwd"] == pytest.approx(vx, rel=1e-5) and m["score/a/fwd"] == 0.0
  dist = np.hypot(x - xb, y - yb)  # about 0.71 < min_dist 5: done, bonus 10
  assert m["reward/a__b/near"] == pytest.approx(-dist + 10.0, rel=1e-5)
  assert m["score/a__b/near"] == pytest.approx(-dist + 10.0, rel=1e-5)
  assert m["reward/a__b/relvel"] == pytest.approx(-abs(vx - vxb), rel=1e-5)
  assert float(state.done) == 1.0
  assert float(state.reward) == pytest.approx(sum(m[f"reward/{t}"] for t in env.reward_terms),
                                              rel=1e-5)


def test_wrappers_truncate_repeat_and_auto_reset():
  base = envs.create("point_goal", episode_length=None)
  env = envs.auto_reset(envs.episode(envs.action_repeat(base, 2), 4))
  reset, step = jax.jit(env.reset), jax.jit(env.step)
  state = reset(jax.random.PRNGKey(0))
  first_obs = np.asarray(state.obs)
  action = jnp.array([1.0, 0.0])
  s1 = step(state, action)
  # Action repeat: the reward is the sum over two base steps.
  b0 = jax.jit(base.reset)(jax.random.PRNGKey(0))
  b1 = jax.jit(base.step)(b0, action)
  b2 = jax.jit(base.step)(b1, action)
  assert float(s1.reward) == pytest.approx(float(b1.reward + b2.reward), rel=1e-5)
  np.testing.assert_allclose(s1.obs, b2.obs, rtol=1e-6)
  assert float(s1.done) == 0.0 and float(s1.info["steps"]) == 2  # counts unrepeated steps
  s2 = step(s1, action)
  # 4 base steps: time is up; truncation (not termination) and the obs returns to the reset obs.
  assert float(s2.done) == 1.0 and float(s2.truncation) == 1.0
  np.testing.assert_allclose(s2.obs, first_obs)
  s3 = step(s2, action)
  assert float(s3.done) == 0.0 and float(s3.info["steps"]) == 2


def test_edits_and_env_params():
  env = envs.create("ant_push", edits={"components.cap1.reward_fns.goal.scale": 0.5})
  assert env.desc["components"]["cap1"]["reward_fns"]["goal"]["scale"] == 0.5
  six = envs.create("pro_ant_run", num_legs=6)
  assert six.action_size == 12 and six.observation_size == 1 + 4 + 12 + 3 + 3 + 12 + 6 * 13
  assert envs.create("ant").xml != six.xml


def test_pro_ant_legs_are_evenly_spaced():
  import mujoco
  env = envs.create("pro_ant_run", num_legs=5)
  model = env.mj_model
  angles = []
  for i in range(1, 6):
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"agent1/thigh_{i}")
    x, y, _ = model.body_pos[bid]
    angles.append(np.arctan2(y, x) % (2 * np.pi))
  np.testing.assert_allclose(np.diff(angles), 2 * np.pi / 5, atol=1e-5)
