"""benchmarks/root_velocity.py: which way a run's body moves, in the world and in its own frame,
on a stand-in env whose episodes are known."""

import json
import math
from types import SimpleNamespace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, metrics, objectives
from blx.envs.env import State
from blx.experiments import runs
from tests.experiments import load_benchmark

root_velocity = load_benchmark("root_velocity")


class _Data(NamedTuple):
  xmat: jax.Array  # [bodies, 3, 3], as MJX's
  t: jax.Array


class _Runner:
  """An episode draws its body's heading at reset (uniform) and keeps it; the body runs at 2 m/s
  60 degrees to the left of its own x axis, so its world direction is the heading + 60 degrees.
  Reward 1.5 a step. Its observation: [yaw, vx, vy]."""

  observation_size, action_size = 3, 1
  named_indices = {"vel_xy": (1, 2)}

  def obs_indices(self, name):
    return self.named_indices[name]

  def _fields(self, yaw, t):
    c, s = jnp.cos(yaw), jnp.sin(yaw)
    xmat = jnp.zeros((2, 3, 3)).at[1].set(jnp.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
    v = 2.0 * jnp.stack([jnp.cos(yaw + math.pi / 3), jnp.sin(yaw + math.pi / 3)])
    return dict(data=_Data(xmat=xmat, t=t), obs=jnp.concatenate([yaw[None], v]),
                reward=jnp.float32(1.5))

  def reset(self, key):
    yaw = jax.random.uniform(key, (), minval=-math.pi, maxval=math.pi)
    return State(**self._fields(yaw, jnp.zeros((), jnp.int32)), done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(**self._fields(state.obs[0], state.data.t + 1))


def test_the_body_frame_direction_is_found_whatever_way_each_episode_faces():
  run = SimpleNamespace(env=envs.episode(_Runner(), 8), objective=objectives.task(),
                        policy=lambda params, obs, z=None, key=None, deterministic=False:
                        jnp.zeros(obs.shape[:-1] + (1,)))
  arrays = jax.jit(lambda k: root_velocity.episodes(run, {}, k, 30, False))(jax.random.PRNGKey(0))
  velocity, x_axis, up, reward = (np.asarray(a) for a in arrays)
  assert velocity.shape == (30, 4, 2) and x_axis.shape == (30, 4, 2)  # the scored half of 8
  read = root_velocity.read_seed(velocity, x_axis, up, reward)
  assert read["body_direction_deg"] == pytest.approx(60.0, abs=1e-3)
  assert read["body_velocity"] == pytest.approx([1.0, math.sqrt(3.0)], abs=1e-4)
  assert read["speed"] == pytest.approx(2.0, abs=1e-5)
  # 30 headings drawn at random: the world velocities point every way, so their mean is short
  assert read["steadiness"] < 0.5
  assert read["reward"] == pytest.approx(1.5) and read["upside_down"] == 0.0


class _Steered(_Runner):
  """As ``_Runner``, but the body runs along its own x axis at 1 + |action| m/s from the first
  step on; the observation: [yaw, vx, vy, speed]."""

  observation_size = 4
  named_indices = {"vel_xy": (1, 2)}

  def _steered(self, yaw, speed, t):
    c, s = jnp.cos(yaw), jnp.sin(yaw)
    xmat = jnp.zeros((2, 3, 3)).at[1].set(jnp.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
    return dict(data=_Data(xmat=xmat, t=t), reward=jnp.float32(0.0),
                obs=jnp.concatenate([yaw[None], speed * jnp.stack([c, s]), speed[None]]))

  def reset(self, key):
    yaw = jax.random.uniform(key, (), minval=-math.pi, maxval=math.pi)
    return State(**self._steered(yaw, jnp.float32(0.0), jnp.zeros((), jnp.int32)),
                 done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(**self._steered(state.obs[0], 1.0 + jnp.abs(action[0]), state.data.t + 1))


def test_a_policy_that_takes_a_latent_runs_under_each_of_the_evaluators_latents():
  objective = objectives.gcrl(obs_indices=(1, 2))   # a continuous prior over two dimensions
  seen = []

  def policy(params, obs, z=None, key=None, deterministic=False):
    seen.append(z is not None)
    return z[..., :1]   # the first latent dimension is the action, so each skill its own speed
  run = SimpleNamespace(env=envs.episode(_Steered(), 8), policy=policy, objective=objective)
  key = jax.random.PRNGKey(3)
  arrays = jax.jit(lambda k: root_velocity.episodes(run, {}, k, 2, False, 5))(key)
  velocity, x_axis, up, reward = (np.asarray(a) for a in arrays)
  assert velocity.shape == (10, 4, 2) and all(seen)   # 5 latents x 2 episodes, each conditioned
  z = np.asarray(metrics.latents_for_evaluation(objective, jax.random.fold_in(key, 1), 5))
  speeds = np.linalg.norm(velocity, axis=-1)  # episode by episode: latent 0's two, then 1's, ...
  np.testing.assert_allclose(speeds, np.repeat(1.0 + np.abs(z[:, 0]), 2)[:, None].repeat(4, 1),
                             rtol=1e-5)
  read = root_velocity.read_seed(velocity, x_axis, up, reward)
  assert read["speed"] == pytest.approx(1.0 + np.abs(z[:, 0]).mean(), rel=1e-5)
  assert read["body_direction_deg"] == pytest.approx(0.0, abs=1e-3)   # along its own x axis
  latents, conditioned = root_velocity.common.policy_latents(run, jax.random.fold_in(key, 1), 5)
  np.testing.assert_array_equal(np.asarray(latents), z)
  latents, conditioned_task = root_velocity.common.policy_latents(
      SimpleNamespace(objective=objectives.task()), key)   # a task's policy takes none
  assert conditioned and not conditioned_task and latents.shape == (1, 0)


def test_a_steady_run_in_the_world_and_its_heading():
  t = 50
  yaw = np.full((2, t), math.radians(-30.0))
  x_axis = np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)
  velocity = np.broadcast_to([3.0, 0.0], (2, t, 2))  # along +x, the body turned 30 deg right
  up = np.concatenate([np.ones((1, t)), -np.ones((1, t))])  # one episode on its back
  read = root_velocity.read_seed(velocity, x_axis, up, np.zeros((2, t)))
  assert read["velocity"] == [3.0, 0.0] and read["steadiness"] == pytest.approx(1.0)
  assert read["heading_deg"] == pytest.approx(-30.0)
  assert read["body_direction_deg"] == pytest.approx(30.0)  # +x is 30 deg left of its nose
  assert read["upside_down"] == 0.5


def test_the_summary_averages_angles_as_angles():
  seeds = [dict(speed=1.0, body_direction_deg=170.0, heading_deg=0.0, velocity=[1.0, 0.0]),
           dict(speed=3.0, body_direction_deg=-170.0, heading_deg=0.0, velocity=[3.0, 2.0])]
  out = root_velocity.summary(seeds)
  assert abs(out["body_direction_deg"]["mean"]) == pytest.approx(180.0)  # not 0
  assert out["body_direction_deg"]["std"] == pytest.approx(
      math.degrees(math.sqrt(-2 * math.log(math.cos(math.radians(10.0))))))
  assert out["heading_deg"] == {"mean": 0.0, "std": 0.0}
  assert out["speed"] == {"mean": 2.0, "std": 1.0}
  assert out["velocity"] == {"mean": [2.0, 1.0], "std": [1.0, 1.0]}


def test_the_command_refuses_an_env_without_a_planar_root_velocity(monkeypatch, capsys, tmp_path):
  run = SimpleNamespace(spec=SimpleNamespace(seeds=(0,), env="cheetah_like", objective="task"),
                        env=SimpleNamespace(named_indices={"vel_x": (3,)}),
                        objective=objectives.task())
  monkeypatch.setattr(root_velocity.common.runs, "load_run", lambda directory: run)
  for argv, message in (([str(tmp_path)], "has no root xy velocity in its observation (its "
                         "named sets: vel_x)"),
                        ([str(tmp_path), "--episodes", "0"], "--episodes 0: give 1 or more"),
                        ([str(tmp_path), "--latents", "0"], "--latents 0: give 1 or more"),
                        ([str(tmp_path), "--latents", "4"], "policy takes no latent (objective "
                         "'task'); --latents counts the draws of a continuous prior")):
    monkeypatch.setattr("sys.argv", ["root_velocity.py", *argv])
    with pytest.raises(SystemExit):
      root_velocity.main()
    assert message in capsys.readouterr().err
  run.objective = objectives.diayn(num_skills=3, obs_indices=(1, 2))   # every skill is run
  monkeypatch.setattr("sys.argv", ["root_velocity.py", str(tmp_path), "--latents", "4"])
  with pytest.raises(SystemExit):
    root_velocity.main()
  assert "runs every skill of its categorical prior" in capsys.readouterr().err


def test_the_json_names_the_runs_settings_and_how_far_it_had_trained(monkeypatch, tmp_path):
  def run(meta):
    spec = SimpleNamespace(seeds=(3, 5), env="runner", env_params={"num_legs": 3},
                           ppo={"entropy_cost": 0.1})
    policy = lambda params, obs, z=None, key=None, deterministic=False: (   # noqa: E731
        jnp.zeros(obs.shape[:-1] + (1,)))
    return runs.Run(directory=str(tmp_path), spec=spec, env=envs.episode(_Runner(), 8),
                    objective=objectives.task(), config=None, params={"w": jnp.zeros((2,))},
                    policy=policy,
                    meta=meta)
  out = tmp_path / "velocity.json"
  history = [{"env_steps": 1e6}, {"env_steps": 2e6}]
  for meta, env_steps in (({"history": history}, 2e6),
                          # a checkpoint within a chunk, past the last evaluation
                          ({"history": history, "env_steps": 2.5e6}, 2.5e6),
                          ({}, None)):   # no history: how far it trained is not known
    monkeypatch.setattr(root_velocity.common.runs, "load_run", lambda directory: run(meta))
    monkeypatch.setattr("sys.argv", ["root_velocity.py", str(tmp_path), "--episodes", "2",
                                     "--out", str(out)])
    root_velocity.main()
    result = json.loads(out.read_text())
    assert result["env_steps"] == env_steps
    assert result["ppo"] == {"entropy_cost": 0.1} and result["env_params"] == {"num_legs": 3}
    assert result["latents"] is None   # its policy takes none
    assert sorted(result["per_seed"]) == ["3", "5"]
    assert result["summary"]["speed"]["mean"] == pytest.approx(2.0, abs=1e-5)
