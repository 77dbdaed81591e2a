"""benchmarks/seed_paths.py: every seed's skill paths, on a body whose path per skill and seed is
known."""

import json
from types import SimpleNamespace

import flax.struct
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, objectives
from blx.envs.env import State
from tests.experiments import load_benchmark

seed_paths = load_benchmark("seed_paths")

DIRECTIONS = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]], np.float32)  # skill k's heading
STEPS = 6


@flax.struct.dataclass
class _Bodies:
  xpos: jax.Array  # [bodies, 3], as MJX's data: body 0 the world, body 1 the agent's root


class _Walker:
  """Body 1 moves by the action (its xy) every step."""

  observation_size, action_size = 1, 2

  def reset(self, key):
    return State(data=_Bodies(jnp.zeros((2, 3))), obs=jnp.zeros(1), reward=jnp.zeros(()),
                 done=jnp.zeros(()))

  def step(self, state, action):
    xpos = state.data.xpos.at[1, :2].add(action)
    return state.replace(data=_Bodies(xpos), obs=xpos[1, :1])


def _policy(params, obs, z, key=None, deterministic=False):
  return params["speed"] * z @ jnp.asarray(DIRECTIONS)  # skill k walks DIRECTIONS[k] at speed


def _run(directory="runs/x", speeds=(1.0, 3.0)):
  return SimpleNamespace(
      directory=directory, env=envs.episode(_Walker(), STEPS), policy=_policy,
      params={"speed": jnp.asarray(speeds)},
      spec=SimpleNamespace(seeds=(4, 7), objective="diayn", env="point", env_params={},
                           ppo={}),
      objective=objectives.diayn(num_skills=4, obs_indices=(0,)))


def test_every_seed_walks_its_own_params_under_every_skill():
  run = _run()
  xy = seed_paths.seed_paths(run, [1, 0], deterministic=True)
  assert xy.shape == (2, 4, seed_paths.EPISODES, STEPS, 2)
  t = np.arange(1, STEPS + 1, dtype=np.float32)
  for position, speed in ((0, 3.0), (1, 1.0)):  # the positions' order, not the run's
    for k in range(4):
      want = speed * t[:, None] * DIRECTIONS[k]
      for m in range(seed_paths.EPISODES):
        np.testing.assert_allclose(xy[position, k, m], want, atol=1e-6)


def test_each_seed_gets_its_mi_from_eval_json(tmp_path):
  (tmp_path / "eval.json").write_text(json.dumps(
      {"seeds": [4, 7], "per_seed": {"eval/mi": [0.5, 1.25]}}))
  assert seed_paths.seed_mis(str(tmp_path), [7, 4]) == [1.25, 0.5]
  assert seed_paths.seed_mis(str(tmp_path / "none"), [4]) == [None]


def test_the_figure_has_a_panel_per_seed_on_one_scale(tmp_path, monkeypatch):
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  figures = []
  monkeypatch.setattr(plt, "close", figures.append)  # keep the figure to look at
  near = np.zeros((2, 4, 1, 3, 2))
  near[..., 0] = np.linspace(0, 1, 3)
  far = near * 10
  path = str(tmp_path / "p.png")
  seed_paths.draw([("A", [0, 1], [0.5, None], near), ("B", [3], [1.0], far[:1])], path,
                  body="torso", title="t")
  (fig,) = figures
  axes = np.array(fig.axes).reshape(2, 2)
  assert [ax.get_title() for ax in axes[0]] == ["seed 0, MI 0.50", "seed 1"]
  assert axes[1, 0].get_title() == "seed 3, MI 1.00" and not axes[1, 1].axison
  assert axes[0, 0].get_xlim() == axes[1, 0].get_xlim()  # one scale: B's 10 m reach A's panels
  assert axes[0, 0].get_xlim()[1] >= 10
  assert (tmp_path / "p.png").stat().st_size > 0


def test_the_command_draws_every_run_and_refuses_what_it_cannot(tmp_path, monkeypatch, capsys):
  a, b = _run(str(tmp_path / "a")), _run(str(tmp_path / "b"), speeds=(2.0, 2.0))
  (tmp_path / "a").mkdir()
  gail = SimpleNamespace(spec=SimpleNamespace(objective="gail"),
                         objective=objectives.gail(obs_indices=(0,)))
  by_dir = {a.directory: a, b.directory: b, "g": gail}
  monkeypatch.setattr(seed_paths.runs, "load_run", lambda d: by_dir[d])
  monkeypatch.setattr(seed_paths.plots, "root_body", lambda env: "root")
  drawn = []
  monkeypatch.setattr(seed_paths, "draw", lambda rows, path, **kw: drawn.append((rows, path)))
  assert seed_paths.main([a.directory, b.directory, "--labels", "fast,even", "--seeds", "1"]) == 0
  ((rows, path),) = drawn
  assert path == str(tmp_path / "a" / "seed_paths.png")
  assert [(label, seeds) for label, seeds, _, _ in rows] == [("fast", [7]), ("even", [7])]
  assert rows[0][3][0, 0, 0, -1, 0] == pytest.approx(3.0 * STEPS)
  # Each run's reach, first to last position of an episode: (STEPS - 1) steps at its speed.
  summary = json.loads((tmp_path / "a" / "seed_paths.json").read_text())
  assert summary["fast"]["seeds"] == [7] and summary["fast"]["mi"] == [None]
  assert summary["fast"]["reach_m"] == [pytest.approx(3.0 * (STEPS - 1))]
  assert summary["even"]["reach_m"] == [pytest.approx(2.0 * (STEPS - 1))]
  for argv, message in (([a.directory, "--labels", "x,y"], "--labels: 2 names for 1 runs"),
                        ([a.directory, b.directory, "--labels", "x,x"], "one distinct name"),
                        ([a.directory, "--out", "p.jpg"], "give a .png path"),
                        (["g"], "gail has no skills"),
                        ([a.directory, "--seeds", "2"], "--seeds 2: the run has 2 seeds")):
    with pytest.raises(SystemExit):
      seed_paths.main(argv)
    assert message in capsys.readouterr().err
