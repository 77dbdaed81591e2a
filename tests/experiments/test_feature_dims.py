"""benchmarks/feature_dims.py: MI and H(s) per observation dimension of a policy."""

import json
import math
import pathlib
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import objectives
from tests.conftest import make_env
from tests.experiments import load_benchmark

feature_dims = load_benchmark("feature_dims")


def _split_on_x(params, obs, z, key=None, deterministic=False):
  """Skill 0 pushes the point to +x at full force, skill 1 to -x; nothing moves it in y."""
  return jnp.stack([z[:, 0] - z[:, 1], jnp.zeros(z.shape[0])], -1)


def test_scan_finds_the_skill_in_the_dimension_the_policy_uses_and_none_elsewhere(tmp_path):
  env = make_env("point")  # observation: x, y, vx, vy
  objective = objectives.make("diayn", num_skills=2, obs_indices="pos_xy", env=env)
  scan = jax.jit(lambda key: feature_dims.scan(env, objective, _split_on_x, None, [0, 1, 2, 3], key,
                                                last_steps=25))  # as scan_run runs it
  r = jax.device_get(scan(jax.random.PRNGKey(0)))
  # x velocity: the two skills never share a bin, so MI = H(s) = log 2 (two equal skills).
  assert r["mi"][2] == np.float32(math.log(2)) and r["entropy"][2] == np.float32(math.log(2))
  # y and its velocity stay 0 for both skills: no information and no spread.
  np.testing.assert_allclose(r["mi"][[1, 3]], 0.0, atol=1e-6)
  np.testing.assert_allclose(r["entropy"][[1, 3]], 0.0, atol=1e-6)
  # x position: the skills part too, but both leave the +-obs_scale box the estimator bins, so
  # only the samples still inside count.
  assert 0.0 < r["mi"][0] < math.log(2)

  results = {"split": {k: np.stack([v, v]) for k, v in r.items()}}
  path = str(tmp_path / "dims.png")
  feature_dims.plot(results, [0, 1, 2, 3], path)
  assert pathlib.Path(path).stat().st_size > 10_000


def test_scan_run_takes_the_seeds_at_the_positions_asked_in_that_order(monkeypatch):
  env = make_env("point")
  objective = objectives.make("diayn", num_skills=2, obs_indices="pos_xy", env=env)

  def scaled_split(params, obs, z, key=None, deterministic=False):  # params: this seed's force
    return params * _split_on_x(None, obs, z)

  run = SimpleNamespace(env=env, objective=objective, policy=scaled_split,
                        params=jnp.array([0.0, 1.0]), spec=SimpleNamespace(seeds=(7, 8)))
  monkeypatch.setattr("blx.experiments.runs.load_run", lambda directory: run)
  r = feature_dims.scan_run("runs/x", [2], positions=[1, 0])
  # Position 1 (force 1) parts the two skills in x velocity; position 0 (force 0) never moves.
  np.testing.assert_allclose(r["mi"][:, 0], [math.log(2), 0.0], atol=1e-6)


def test_the_command_refuses_a_seed_a_run_does_not_have(monkeypatch, capsys):
  monkeypatch.setattr("blx.experiments.runs.read_spec",
                      lambda directory: SimpleNamespace(seeds=(0, 1), objective="diayn"))
  for argv, message in ((["runs/a", "--seeds", "0,3"], "runs/a: --seeds 3: the run has 2 seeds"),
                        (["runs/a", "--seeds", "x"], "runs/a: --seeds 'x': give comma-separated"),
                        (["runs/a", "runs/a"], "a run directory is given twice")):
    with pytest.raises(SystemExit):
      feature_dims.main(argv)
    assert message in capsys.readouterr().err


def test_legend_entries_stay_apart_when_two_runs_share_an_objective():
  spec = SimpleNamespace(objective="diayn")
  assert feature_dims.run_labels({"sweeps/a/objective=diayn": spec,
                                  "sweeps/b/lr=0.001": spec}) == {
      "sweeps/a/objective=diayn": "diayn", "sweeps/b/lr=0.001": "diayn (lr=0.001)"}
  # Two sweeps' points of one name would share "diayn": the whole paths part them.
  assert feature_dims.run_labels({"sweeps/a/objective=diayn": spec,
                                  "sweeps/b/objective=diayn": spec}) == {
      "sweeps/a/objective=diayn": "diayn (sweeps/a/objective=diayn)",
      "sweeps/b/objective=diayn": "diayn (sweeps/b/objective=diayn)"}


def test_labels_name_the_runs_in_the_figure_and_its_json(monkeypatch, tmp_path):
  env = make_env("point")
  monkeypatch.setattr("blx.experiments.runs.read_spec",
                      lambda directory: SimpleNamespace(seeds=(0,), objective="diayn",
                                                        env="point"))
  monkeypatch.setattr("blx.experiments.runs.build", lambda spec: (env, None, None))
  mi = {"runs/a": 0.5, "runs/b": 0.1}
  monkeypatch.setattr(feature_dims, "scan_run", lambda directory, dims, positions: {
      "mi": np.full((1, len(dims)), mi[directory]), "entropy": np.ones((1, len(dims)))})
  out = tmp_path / "dims.png"
  feature_dims.main(["runs/a", "runs/b", "--dims", "2", "--labels", "xy velocity,whole obs",
                     "--out", str(out)])
  saved = json.loads(out.with_suffix(".json").read_text())
  assert list(saved) == ["xy velocity", "whole obs"]
  assert saved["xy velocity"]["mi"] == [[0.5, 0.5]] and saved["whole obs"]["mi"] == [[0.1, 0.1]]
  assert out.stat().st_size > 10_000


@pytest.mark.parametrize("labels", ["only one", "a,a", "a,"])
def test_labels_must_name_each_run_once(labels, monkeypatch, capsys):
  monkeypatch.setattr("blx.experiments.runs.read_spec",
                      lambda directory: SimpleNamespace(seeds=(0,), objective="diayn"))
  with pytest.raises(SystemExit):
    feature_dims.main(["runs/a", "runs/b", "--labels", labels])
  assert "give 2 distinct names, one per run" in capsys.readouterr().err
