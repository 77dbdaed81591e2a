"""benchmarks/posture.py: each episode's posture (upright or on its back) beside its matched
feature, on a stand-in env whose episodes are known."""

from types import SimpleNamespace
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, objectives
from blx.envs.env import State
from blx.objectives.targets import Target
from tests.experiments import load_benchmark

posture = load_benchmark("posture")

TARGET = Target(samples=jnp.array([[-2.0], [2.0]]), log_prob=None, name="two points",
                means=jnp.array([[-2.0], [2.0]]))


class _Data(NamedTuple):
  xmat: jax.Array  # [bodies, 3, 3], as MJX's
  t: jax.Array


class _BackOrRun:
  """An episode draws at reset whether its body lies on its back. Upright it runs backward at -2
  every step; on its back its feature swings -2, +2, -2, ... (it rocks). Its observation: the
  feature, and whether it is on its back."""

  observation_size, action_size = 2, 1

  def _fields(self, back, t):
    up = jnp.where(back, -1.0, 1.0)
    xmat = jnp.zeros((2, 3, 3)).at[1, 2, 2].set(up)  # body 1, the root: its up axis
    feature = jnp.where(back, jnp.where(t % 2 == 0, -2.0, 2.0), -2.0)
    return dict(data=_Data(xmat=xmat, t=t), obs=jnp.stack([feature, back.astype(jnp.float32)]))

  def reset(self, key):
    return State(**self._fields(jax.random.bernoulli(key), jnp.zeros((), jnp.int32)),
                 reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(**self._fields(state.obs[1] > 0.5, state.data.t + 1))


def _run():
  return SimpleNamespace(env=envs.episode(_BackOrRun(), 8),
                         policy=lambda params, obs, z=None, key=None, deterministic=False:
                         jnp.zeros(obs.shape[:-1] + (1,)),
                         objective=objectives.gail(target=TARGET, obs_indices=(0,)))


def test_each_episode_is_read_upright_or_on_its_back_with_its_feature_and_modes():
  feature, up = jax.jit(lambda k: posture.episodes(_run(), {}, k, 40, False))(
      jax.random.PRNGKey(0))
  assert feature.shape == (40, 4, 1) and up.shape == (40, 4)  # the scored half of 8 steps
  read = posture.per_episode(np.asarray(feature), np.asarray(up), np.array([[-2.0], [2.0]]))
  backs = [e for e in read if e["upside_down"] > 0.5]
  upright = [e for e in read if e["upside_down"] <= 0.5]
  assert 0 < len(backs) < 40 and all(e["upside_down"] == 1.0 for e in backs)
  for e in upright:  # runs backward: all at mode 0
    assert e["feature"] == [-2.0] and e["feature_std"] == [0.0] and e["mode_share"] == [1.0, 0.0]
  for e in backs:  # rocks: half its states at each mode, a mean of 0 and a std of 2
    assert e["feature"] == [0.0] and e["feature_std"] == [2.0] and e["mode_share"] == [0.5, 0.5]
  total = posture.summary([read[:20], read[20:]])
  assert total["on its back"] == {"episodes": len(backs), "feature": [0.0], "feature_std": [2.0],
                                  "mode_share": [0.5, 0.5]}
  assert total["upright"]["episodes"] == 40 - len(backs)
  assert total["upright"]["mode_share"] == [1.0, 0.0]


def test_a_posture_no_episode_took_is_counted_as_none():
  read = posture.per_episode(np.full((3, 5, 1), 1.5), np.ones((3, 5)), None)
  assert "mode_share" not in read[0]  # a target without modes
  assert posture.summary([read]) == {"upright": {"episodes": 3, "feature": [1.5],
                                                 "feature_std": [0.0]},
                                     "on its back": {"episodes": 0}}


def test_the_command_refuses_what_it_cannot_read(monkeypatch, capsys, tmp_path):
  run = SimpleNamespace(spec=SimpleNamespace(seeds=(0, 1), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=4, obs_indices=(0,)))
  monkeypatch.setattr(posture.runs, "load_run", lambda directory: run)
  for argv, message in (([str(tmp_path)], "diayn is not a D-min objective (it has no target)"),
                        ([str(tmp_path), "--episodes", "0"], "--episodes 0: give 1 or more")):
    monkeypatch.setattr("sys.argv", ["posture.py", *argv])
    with pytest.raises(SystemExit):
      posture.main()
    assert message in capsys.readouterr().err
