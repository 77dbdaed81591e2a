"""benchmarks/goal_reach_model.py: a GCRL row's MI and H(s) read as how far its skills reach toward
their goals, under a model of their states scored with the paper's estimator."""

import json
import os

import numpy as np
import pytest

from tests.experiments import load_benchmark

grm = load_benchmark("goal_reach_model")
PAPER_DIR = os.path.join(os.path.dirname(__file__), "..", "..", "benchmarks", "paper")


@pytest.fixture(scope="module")
def model():
  # Small: 2 draws of 10 goals with 2,000 states each (the protocol's is 20 draws of 5,000).
  return grm.Model(dims=2, obs_scale=5.0, latents=10, samples=2000, draws=2)


@pytest.mark.parametrize("form,sigma,reach", [("cap", 0.3, 1.5), ("fraction", 0.4, 0.6)])
def test_the_fit_finds_the_sigma_and_reach_the_states_were_drawn_with(model, form, sigma, reach):
  h, hz = model(reach, sigma, form)
  fitted = grm.fit(model, h, hz, form)
  assert fitted["sigma"] == pytest.approx(sigma, abs=0.01)
  assert fitted["reach"] == pytest.approx(reach, abs=0.05)
  assert (fitted["sigma_bound"], fitted["reach_bound"]) == ("", "")


def test_reach_spreads_the_skills_apart_and_sigma_spreads_each_skill(model):
  rows = [model(reach, 0.3, "cap") for reach in (0.0, 0.5, 1.0, 2.0, 3.6, 5.0)]
  h = [r[0] for r in rows]
  hz = [r[1] for r in rows]
  # H(s) grows with the reach until every goal is reached whole (the box's corner, 3.54 m/s);
  # H(s|z), one skill's spread, does not move with it.
  assert all(b > a + 0.01 for a, b in zip(h[:4], h[1:5]))
  assert h[5] == pytest.approx(h[4], abs=1e-6)
  assert max(hz) - min(hz) < 0.01
  assert model(1.0, 0.5, "cap")[1] > hz[0] + 0.3
  # No reach: every skill's states lie about the origin, so the MI is the estimator's own: a
  # skill's 2,000 states fill fewer bins than all 20,000 together, a small positive bias.
  assert 0 < h[0] - hz[0] < 0.1


def test_a_target_beyond_the_model_is_named_as_a_bound(model):
  h, hz = model(grm.Model.most_reach(model, "cap"), 0.3, "cap")
  fitted = grm.fit(model, h + 0.5, hz, "cap")
  assert fitted["reach_bound"] == "above"
  assert fitted["reach"] == pytest.approx(model.most_reach("cap"))
  assert grm.fit(model, hz - 0.5, hz, "fraction")["reach_bound"] == "below"


def test_swapping_the_parts_of_two_fits_gives_each_fit_s_mi_and_the_mixtures(model):
  blx = {f: grm.fit(model, *model(r, s, f), f) for f, r, s in
         (("cap", 1.0, 0.35), ("fraction", 0.45, 0.35))}
  paper = {f: grm.fit(model, *model(r, s, f), f) for f, r, s in
           (("cap", 2.3, 0.3), ("fraction", 0.9, 0.3))}
  out = grm.swapped(model, paper, blx)
  mi = lambda r, s, f: np.subtract(*model(r, s, f))
  for form in grm.MODELS:
    assert out[form]["blx"] == pytest.approx(mi(blx[form]["reach"], blx[form]["sigma"], form))
    # The paper's reach with blx's spread scores between the two rows: both parts count.
    assert out[form]["blx"] < out[form]["blx_sigma_paper_reach"] < out[form]["paper"]
    assert out[form]["blx"] < out[form]["paper_sigma_blx_reach"] < out[form]["paper"]


def test_a_gcrl_eval_json_is_read_and_another_objective_is_refused():
  with open(os.path.join(PAPER_DIR, "brax_ant_5ms", "gcrl_eval.json")) as f:
    row = json.load(f)
  mean, seeds = grm.row_means(row)
  assert mean["eval/entropy"] == row["summary"]["eval/entropy"]["mean"]
  assert len(seeds) == len(row["seeds"]) == 10
  assert np.mean([s["eval/conditional_entropy"] for s in seeds]) == pytest.approx(
      mean["eval/conditional_entropy"], rel=1e-5)
  with open(os.path.join(PAPER_DIR, "brax_ant_5ms", "diayn_eval.json")) as f:
    with pytest.raises(ValueError, match="'diayn'"):
      grm.row_means(json.load(f))
  with pytest.raises(ValueError, match="cap, fraction"):
    grm.reached(np.zeros((1, 2)), 1.0, "clip")


@pytest.mark.parametrize("argv,message", [
    (["brax_humanoid/gcrl_eval.json", "--env", "ant"], "is a humanoid row"),
    (["brax_ant_5ms/gcrl_eval.json", "--dims", "1"], "scored 2 dimensions"),
    (["brax_ant_5ms/diayn_eval.json"], "'diayn'"),
    (["no_such_row/eval.json"], "No such file"),
])
def test_the_command_refuses_a_row_it_cannot_read_naming_why(argv, message, monkeypatch, capsys):
  argv = [os.path.join(PAPER_DIR, argv[0]), *argv[1:]]
  monkeypatch.setattr("sys.argv", ["goal_reach_model.py", *argv])
  with pytest.raises(SystemExit):
    grm.main()
  assert message in capsys.readouterr().err


def test_a_row_without_per_dimension_mi_asks_for_its_dimensions(tmp_path, monkeypatch, capsys):
  with open(os.path.join(PAPER_DIR, "brax_ant_5ms", "gcrl_eval.json")) as f:
    row = json.load(f)
  for key in [k for k in row["summary"] if k.startswith("eval/mi_1d/")]:
    del row["summary"][key]
  path = tmp_path / "eval.json"
  path.write_text(json.dumps(row))
  monkeypatch.setattr("sys.argv", ["goal_reach_model.py", str(path)])
  with pytest.raises(SystemExit):
    grm.main()
  assert "give --dims" in capsys.readouterr().err


def _gcrl_run(path, protocol=None):
  """A GCRL run under training: two evaluations every seed reached, a third that seed 2 has not
  yet; with ``protocol``, a provenance segment that records it."""
  from tests.experiments.test_paper_tables import _run_dir
  keys = ("eval/entropy", "eval/conditional_entropy", "eval/mi_1d/13", "eval/mi_1d/14")
  run = _run_dir(path, "gcrl", "ant", [
      (1e6, 10.0, dict(zip(keys, ([4.6, 4.7, 4.8], [4.5, 4.6, 4.7], [0.1] * 3, [0.1] * 3)))),
      (2e6, 20.0, dict(zip(keys, ([5.5, 5.6, 5.7], [4.8, 4.9, 5.0], [0.6] * 3, [0.8] * 3)))),
      (3e6, 30.0, dict(zip(keys, ([5.9, 5.9], [4.8, 4.8], [0.9] * 2, [0.9] * 2))))])
  if protocol:
    (path / "provenance.json").write_text(json.dumps({"segments": [{
        "started": "2026-12-05T00:00:00Z", "from_env_steps": 0.0, "to_env_steps": 3e6,
        "device": "cpu", "platform": "cpu", "device_count": 1, "versions": {},
        "eval_protocol": protocol}]}))
  return run


def test_a_run_under_training_is_read_at_its_last_evaluation_every_seed_reached(tmp_path):
  row = grm.run_row(str(_gcrl_run(tmp_path / "quick")))
  assert (row["env_steps"], row["eval_protocol"], row["env"]) == (2e6, "quick", "ant")
  assert row["per_seed"]["eval/conditional_entropy"] == [4.8, 4.9, 5.0]
  mean, seeds = grm.row_means(row)
  assert mean["eval/entropy"] == pytest.approx(5.6)
  assert [s["eval/entropy"] for s in seeds] == [5.5, 5.6, 5.7]
  assert grm.row_dims(row) == 2
  assert grm.run_row(str(_gcrl_run(tmp_path / "final", "final")))["eval_protocol"] == "final"


def test_a_run_is_modelled_at_its_evaluations_sizes_unless_told(tmp_path, monkeypatch, capsys):
  run = _gcrl_run(tmp_path / "run")
  for extra, latents in (([], grm.ROLLOUTS["quick"]), (["--latents", "10"], 10)):
    out = tmp_path / f"fit{latents}.json"
    monkeypatch.setattr("sys.argv", ["goal_reach_model.py", str(run), "--steps", "20", "--draws",
                                     "1", "--out", str(out), *extra])
    grm.main()
    fits = json.loads(out.read_text())
    assert (fits["latents"], fits["samples_per_latent"]) == (latents, 4 * 20)
    assert fits["evaluation"] == {"env_steps": 2e6, "eval_protocol": "quick"}
    assert fits["rows"]["blx"]["entropy"] == pytest.approx(5.6)
    assert f"quick (4 goals x 4 episodes); the model draws {latents} x 4" in capsys.readouterr().out


def test_a_directory_without_one_gcrl_run_is_refused_naming_why(tmp_path):
  with pytest.raises(ValueError, match="no metrics.csv"):
    grm.run_row(str(tmp_path))
  _gcrl_run(tmp_path / "a")
  _gcrl_run(tmp_path / "b")
  with pytest.raises(ValueError, match="2 runs under"):
    grm.run_row(str(tmp_path))
  from tests.experiments.test_paper_tables import _run_dir
  bare = _run_dir(tmp_path / "bare", "gcrl", "ant", [(1e6, 10.0, {"eval/mi": [0.1, 0.2, 0.3]})])
  with pytest.raises(ValueError, match="no evaluation with H\\(s\\|z\\)"):
    grm.run_row(str(bare))


def test_a_prediction_scores_the_states_it_names_without_fitting(tmp_path, model, capsys):
  out = tmp_path / "predicted.json"
  grm.main([os.path.join(PAPER_DIR, "brax_ant_5ms", "gcrl_eval.json"), "--predict",
            "cap:1.5:0.3", "--predict", "fraction:0.6:0.4", "--steps", "200", "--draws", "2",
            "--out", str(out)])
  written = json.loads(out.read_text())
  # the protocol's sizes of a finished row (10 x 10), at the steps asked for
  assert (written["latents"], written["samples_per_latent"]) == (10, 10 * 200)
  # the same states the model's own call scores (the fixture draws 10 goals x 2,000 states too)
  for p, (form, reach, sigma) in zip(written["predictions"],
                                     (("cap", 1.5, 0.3), ("fraction", 0.6, 0.4))):
    assert (p["form"], p["reach"], p["sigma"]) == (form, reach, sigma)
    h, hz = model(reach, sigma, form)
    assert (p["entropy"], p["conditional_entropy"]) == pytest.approx((h, hz), abs=1e-5)
    assert p["mi"] == pytest.approx(h - hz, abs=1e-5)
  # beside the rows' measured values, and no fit
  assert set(written["rows"]) == {"paper", "blx"} and "fits" not in written["rows"]["blx"]
  printed = capsys.readouterr().out
  assert "| cap at 1.5, sigma 0.3 |" in printed and "| 0.6 of each goal, sigma 0.4 |" in printed
  assert "| blx, measured |" in printed and "| row |" not in printed


@pytest.mark.parametrize("given,message", [
    ("cap:1.5", "give FORM:REACH:SIGMA"),
    ("clip:1.5:0.3", "the form 'clip' is not one of cap, fraction"),
    ("cap:fast:0.3", "must be numbers"),
    ("cap:1.5:0", "SIGMA more than 0"),
])
def test_a_bad_prediction_is_named(given, message, capsys):
  with pytest.raises(SystemExit):
    grm.main(["--predict", given])
  assert message in capsys.readouterr().err


def test_measured_means_read_each_goal_off_the_skills_nearest_it():
  candidates = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])
  means = np.array([[0.1, 0.0], [1.5, 0.0], [0.0, 1.0]])
  goals = np.array([[1.8, 0.1], [2.0, 0.0], [0.0, 1.5]])
  np.testing.assert_allclose(grm.measured_means(goals, candidates, means),
                             [[1.5, 0.0], [1.5, 0.0], [0.0, 1.0]])
  # two neighbours, by inverse distance: (0, 1.5) lies 0.5 from (0, 2) and 1.5 from the origin
  np.testing.assert_allclose(grm.measured_means(goals[2:], candidates, means, 2),
                             [[0.75 * 0.0 + 0.25 * 0.1, 0.75 * 1.0]])
  # a goal on a candidate takes that candidate's mean whole, however many neighbours
  np.testing.assert_allclose(grm.measured_means(goals[1:2], candidates, means, 3), [[1.5, 0.0]])


def test_skills_measured_to_run_a_cap_score_what_the_cap_does(model):
  # a dense grid of measured skills that reach their goals up to 1.5: read back per goal, they
  # give the model's own cap at 1.5, and a seed of slower skills gives less H(s)
  axis = np.linspace(-2.5, 2.5, 41)
  candidates = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
  reaching = {"per_seed": {
      "0": {"candidates": candidates.tolist(),
            "candidate_means": grm.reached(candidates, 1.5, "cap").tolist()},
      "1": {"candidates": candidates.tolist(),
            "candidate_means": grm.reached(candidates, 0.5, "cap").tolist()}}}
  out = grm.measured(model, reaching, 0.3)
  h, hz = model(1.5, 0.3, "cap")
  assert out["seeds"] == ["0", "1"]
  assert out["entropy"][0] == pytest.approx(h, abs=0.01)
  assert out["conditional_entropy"][0] == pytest.approx(hz, abs=1e-4)
  assert out["entropy"][1] < out["entropy"][0] - 0.2
  assert out["mi"][0] == pytest.approx(out["entropy"][0] - out["conditional_entropy"][0])
  with pytest.raises(ValueError, match="3 dimensions"):
    grm.measured(model, {"per_seed": {"0": {"candidates": [[0.0, 0.0, 0.0]],
                                            "candidate_means": [[0.0, 0.0, 0.0]]}}}, 0.3)


@pytest.mark.parametrize("argv,message", [
    (["--measured", "reaching.json"], "--measured needs EVAL_JSON"),
    (["ROW", "--measured", "reaching.json", "--predict", "cap:1:0.3"], "give one"),
    (["ROW", "--measured", "no_such.json"], "No such file"),
    (["ROW", "--neighbours", "0"], "--neighbours 0: give 1 or more"),
])
def test_a_bad_measured_reading_is_named(argv, message, capsys):
  row = os.path.join(PAPER_DIR, "brax_ant_5ms", "gcrl_eval.json")
  with pytest.raises(SystemExit):
    grm.main([row if a == "ROW" else a for a in argv])
  assert message in capsys.readouterr().err


def test_the_measured_reading_sets_each_seed_beside_the_evaluations(tmp_path, capsys):
  row = os.path.join(PAPER_DIR, "brax_ant_5ms", "gcrl_eval.json")
  axis = np.linspace(-2.5, 2.5, 5)
  candidates = np.stack(np.meshgrid(axis, axis), -1).reshape(-1, 2)
  seed = {"candidates": candidates.tolist(),
          "candidate_means": grm.reached(candidates, 1.0, "cap").tolist()}
  reaching = tmp_path / "goal_reaching.json"
  reaching.write_text(json.dumps({"per_seed": {str(s): seed for s in range(10)}}))
  out = tmp_path / "measured.json"
  grm.main([row, "--measured", str(reaching), "--steps", "50", "--draws", "1", "--out", str(out)])
  reading = json.loads(out.read_text())["measured"]
  assert len(reading["entropy"]) == 10 and reading["neighbours"] == 1
  # sigma fitted to the row's H(s|z), so the model's H(s|z) is the row's
  with open(row) as f:
    hz = json.load(f)["summary"]["eval/conditional_entropy"]["mean"]
  assert np.mean(reading["conditional_entropy"]) == pytest.approx(hz, abs=0.01)
  printed = capsys.readouterr().out
  assert "| mean |" in printed and "H(s), model less evaluation:" in printed
  reaching.write_text(json.dumps({"per_seed": {"0": seed, "1": seed}}))
  with pytest.raises(SystemExit):
    grm.main([row, "--measured", str(reaching), "--steps", "50", "--draws", "1"])
  assert "it measured seeds ['0', '1'], the evaluation's are ['0'," in capsys.readouterr().err
  # without the evaluation's seed numbers, the counts must still agree
  with open(row) as f:
    anonymous = {k: v for k, v in json.load(f).items() if k != "seeds"}
  (tmp_path / "eval.json").write_text(json.dumps(anonymous))
  with pytest.raises(SystemExit):
    grm.main([str(tmp_path / "eval.json"), "--measured", str(reaching), "--steps", "50",
              "--draws", "1"])
  assert "the evaluation has 10 seeds, the measurement 2" in capsys.readouterr().err
