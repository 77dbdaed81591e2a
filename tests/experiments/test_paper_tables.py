"""benchmarks/paper_tables.py: the paper's rows per env, the sweep specs that train them and the
verdicts that compare blx with them."""

import csv
import dataclasses
import json
import math
import os
import re

import pytest
from scipy import stats

from blx.experiments import runs, sweep
from tests.experiments import load_benchmark

paper_tables = load_benchmark("paper_tables")


@pytest.mark.parametrize("env,steps", [("ant", 60_000_000), ("halfcheetah", 200_000_000),
                                       ("humanoid", 100_000_000)])
def test_specs_train_every_row_of_the_env_with_twice_its_ppo_row(env, steps):
  specs = paper_tables.specs(10, env=env)
  trained = {}
  for family, spec in specs.items():
    for _, run_spec in sweep.expand(spec):
      trained[run_spec.objective] = (family, run_spec)
  assert set(trained) == set(paper_tables.PAPER[env])
  for objective, (family, run_spec) in trained.items():
    assert run_spec.env == env
    assert run_spec.ppo["num_timesteps"] == steps
    assert run_spec.seeds == tuple(range(10))
    assert run_spec.objective_options["obs_indices"] == "vel"
    assert run_spec.objective_options["obs_scale"] == (8.0 if family == "dmin" else 5.0)
    if family == "mimax":
      assert run_spec.objective_options["spectral_norm"] is True


def test_specs_reject_an_env_without_paper_rows():
  with pytest.raises(ValueError, match="hopper.*'ant', 'halfcheetah', 'humanoid'"):
    paper_tables.specs(10, env="hopper")


def test_verdicts_use_the_rows_of_the_env_the_run_trained_on():
  # Humanoid DIAYN's paper MI is 0.927 +- 0.128 (mean - std 0.799), Ant's 1.115 +- 0.268 (0.847):
  # a mean of 0.83 reaches the first and not the second.
  values = [0.80, 0.84, 0.86, 0.82, 0.83]
  run = {"objective": "diayn", "env": "humanoid", "per_seed": {"eval/mi": values}}
  (row,) = [r for r in paper_tables.verdicts(run) if "eval/mi" in r]
  assert row.startswith("| humanoid | diayn | eval/mi |") and "0.927 ± 0.128" in row
  assert row.endswith("| yes |")  # 0.83 >= 0.927 - 0.128
  (row,) = [r for r in paper_tables.verdicts(dict(run, env="ant")) if "eval/mi" in r]
  assert "1.115 ± 0.268" in row and row.endswith("| **no** |")  # 0.83 < 0.847
  # eval.json files written before runs recorded their env are Ant's.
  legacy = {"objective": "diayn", "per_seed": {"eval/mi": values}}
  assert paper_tables.verdicts(legacy) == paper_tables.verdicts(dict(run, env="ant"))


def test_an_lgr_on_other_goals_than_the_papers_says_so():
  # eval.json records the LGR goals its evaluator drew from session 41 on; one that does not, or
  # records the partitionable draw, was scored on other goals than the paper's.
  run = {"objective": "cdiayn", "env": "halfcheetah", "per_seed": {"eval/lgr": [1.0, 1.2]}}
  for evaluated_on, other in (({"lgr_goals": "braxlines"}, False), (None, True),
                              ({"device": "cpu"}, True), ({"lgr_goals": "partitionable"}, True)):
    (row,) = paper_tables.verdicts(dict(run, evaluated_on=evaluated_on))
    assert row.startswith("| halfcheetah | cdiayn | -eval/lgr" + (
        paper_tables.OTHER_GOALS if other else "") + " | -1.100 ± 0.100 (2) |"), row


def test_energy_distance_is_compared_as_minus_the_distance():
  run = {"objective": "gail", "env": "halfcheetah",
         "per_seed": {"eval/energy_distance": [0.4, 0.5, 0.6]}}
  (row,) = paper_tables.verdicts(run)
  assert "-0.500 ± 0.082 (3)" in row and "-0.516 ± 0.640" in row and row.endswith("| yes |")


def test_a_metric_in_braxlines_window_gets_its_own_row_against_the_same_paper_value():
  run = {"objective": "gail", "env": "humanoid",
         "per_seed": {"eval/energy_distance": [2.4, 2.5, 2.6],
                      "eval/energy_distance_braxlines": [1.6, 1.7, 1.8]}}
  fixed, brax = paper_tables.verdicts(run)
  assert "| -eval/energy_distance |" in fixed and "-2.500 ± 0.082 (3)" in fixed
  assert fixed.endswith("| **no** |")  # -2.5 < -1.790 - 0.413
  assert "| -eval/energy_distance (Braxlines' window) |" in brax
  assert "-1.700 ± 0.082 (3)" in brax and "-1.790 ± 0.413" in brax and brax.endswith("| yes |")


def test_welch_matches_scipy_with_both_stds_as_sample_stds():
  values = [1.0, 1.3, 0.7, 1.1]
  mean, std, n = 1.5, 0.2, 10  # the paper's std is over its n seeds (population)
  t, _, p = paper_tables.welch(values, mean, std, n)
  ref = stats.ttest_ind_from_stats(
      sum(values) / 4, stats.tstd(values), 4, mean, std * math.sqrt(n / (n - 1)), n,
      equal_var=False)
  assert t == pytest.approx(ref.statistic) and p == pytest.approx(ref.pvalue)


def _evaluation(objective, seeds, goals="braxlines", env="halfcheetah", **per_seed):
  return {"objective": objective, "env": env, "seeds": list(seeds),
          "evaluated_on": {"lgr_goals": goals}, "per_seed": per_seed}


def test_paired_pairs_two_evaluations_by_seed_number_whatever_their_order():
  # Arm A is B plus 0.1 at every seed but seed 2 (0.1 less), listed in another seed order; seed 9
  # is A's alone and left out.
  mi_b = [1.0, 1.4, 0.8, 1.2]
  mi_a = {3: 1.3, 0: 1.1, 2: 0.7, 1: 1.5, 9: 5.0}
  a = _evaluation("gcrl", mi_a, **{"eval/mi": list(mi_a.values()),
                                    "eval/lgr": [0.2, 0.3, 0.4, 0.1, 0.0]})
  b = _evaluation("gcrl", [0, 1, 2, 3], **{"eval/mi": mi_b, "eval/lgr": [0.5, 0.1, 0.6, 0.3]})
  header, _, mi, lgr = paper_tables.paired(a, b, names=("clip", "row"))
  assert "| clip | row |" in header and "seeds where clip is better" in header
  x, y = [1.1, 1.5, 0.7, 1.3], mi_b  # seeds 0-3, seed 9 left out
  ref = stats.ttest_rel(x, y)
  assert mi.startswith("| eval/mi | 1.150 ± 0.296 | 1.100 ± 0.224 | +0.050 |")
  assert f"| {ref.statistic:+.2f} | {ref.pvalue:.4f} |" in mi and mi.endswith("| 3 of 4 |")
  # The LGR is better lower. A's by seed 0-3: 0.3, 0.1, 0.4, 0.2 against B's 0.5, 0.1, 0.6, 0.3:
  # lower at seeds 0, 2 and 3, level at seed 1.
  assert lgr.startswith("| eval/lgr (lower is better) | 0.250 ± 0.112 | 0.375 ± 0.192 |")
  assert lgr.endswith("| 3 of 4 |")


def test_paired_refuses_two_rows_too_few_shared_seeds_and_lgrs_on_other_goals():
  a = _evaluation("gcrl", [0, 1], **{"eval/mi": [1.0, 1.1], "eval/lgr": [0.2, 0.3]})
  with pytest.raises(ValueError, match="A is gcrl on halfcheetah, B is diayn on halfcheetah"):
    paper_tables.paired(a, dict(a, objective="diayn"))
  with pytest.raises(ValueError, match="at least 2 shared seeds, got \\[1\\]"):
    paper_tables.paired(a, dict(a, seeds=[1, 2]))
  old_goals = dict(a, evaluated_on={"lgr_goals": "partitionable"})
  rows = paper_tables.paired(a, old_goals)
  assert any(r.startswith("| eval/lgr | (not compared: goals braxlines against partitionable)")
             for r in rows)
  assert any(r.startswith("| eval/mi | 1.050") for r in rows)


def test_paired_reads_run_directories_and_names_an_arms_options(tmp_path, capsys, monkeypatch):
  row, arm = tmp_path / "row" / "gcrl" / "run", tmp_path / "clip" / "gcrl" / "run"
  for path, mi, ppo in ((row, [1.0, 1.2], {}), (arm, [1.5, 1.6], {"max_grad_norm": 5})):
    os.makedirs(path)
    (path / "eval.json").write_text(json.dumps(
        _evaluation("gcrl", [0, 1], **{"eval/mi": mi})))
    (path / "config.json").write_text(json.dumps(
        {"env": "halfcheetah", "objective": "gcrl", "ppo": ppo}))
  text = paper_tables.paired_report(str(tmp_path / "clip"), str(tmp_path / "row"))
  assert text.splitlines()[0].startswith("A: ")  # both runs are named "run": A and B
  assert "| eval/mi | 1.550 ± 0.050 | 1.100 ± 0.100 | +0.450 |" in text
  assert "max_grad_norm 5 (the original's: None)" in text
  (row / "config.json").write_text("{")  # a config that cannot be read is said, not skipped
  text = paper_tables.paired_report(str(tmp_path / "clip"), str(tmp_path / "row"))
  assert "its settings were not checked against the original's" in text
  with pytest.raises(ValueError, match="2 eval.json files under it"):
    paper_tables.read_eval(str(tmp_path))
  with pytest.raises(ValueError, match="neither an eval.json file nor a directory"):
    paper_tables.read_eval(str(tmp_path / "missing"))
  monkeypatch.setattr("sys.argv", ["paper_tables.py", "--paired", str(tmp_path), str(row)])
  with pytest.raises(SystemExit):
    paper_tables.main()
  assert "--paired: " in capsys.readouterr().err


def test_a_row_split_over_programs_trains_disjoint_seeds_and_merges_into_one_row(tmp_path):
  first = paper_tables.specs(4, env="ant")["dmin"]
  rest = paper_tables.specs(6, env="ant", first_seed=4)["dmin"]
  assert first["seeds"] == [0, 1, 2, 3] and rest["seeds"] == [4, 5, 6, 7, 8, 9]
  # Two programs' eval.json at the same path: one 10-seed row, values in seed order.
  for name, seeds in (("a", [4, 5, 6, 7, 8, 9]), ("b", [0, 1, 2, 3])):
    run = tmp_path / name / "dmin" / "mle"
    run.mkdir(parents=True)
    values = [0.1 * s for s in seeds]
    (run / "eval.json").write_text(json.dumps(
        {"objective": "mle", "env": "ant", "seeds": seeds,
         "per_seed": {"eval/energy_distance": values}}))
  table = paper_tables.compare(str(tmp_path / "a"), str(tmp_path / "b"))
  (row,) = [r for r in table.splitlines() if "| mle |" in r]
  assert "-0.450 ± 0.287 (10)" in row  # mean of 0.0 .. 0.9, population std
  merged = paper_tables.merge([
      {"objective": "mle", "seeds": [2, 0], "per_seed": {"x": [2.0, 0.0]}},
      {"objective": "mle", "seeds": [1], "per_seed": {"x": [1.0]}}])
  assert merged["seeds"] == [0, 1, 2] and merged["per_seed"]["x"] == [0.0, 1.0, 2.0]
  with pytest.raises(ValueError, match="overlap"):
    paper_tables.merge([{"objective": "mle", "seeds": [0, 1], "per_seed": {}},
                        {"objective": "mle", "seeds": [1], "per_seed": {}}])
  with pytest.raises(ValueError, match="not the row"):
    paper_tables.merge([{"objective": "mle", "seeds": [0], "per_seed": {}},
                        {"objective": "gail", "seeds": [1], "per_seed": {}}])


def test_compare_names_a_folder_without_evaluations_and_files_that_are_not_one_row(
    tmp_path, monkeypatch, capsys):
  for env in ("ant", "humanoid"):  # committed rows of two envs, each folder with gail_eval.json
    os.makedirs(tmp_path / env)
    (tmp_path / env / "gail_eval.json").write_text(json.dumps(
        _evaluation("gail", [0, 1], env=env, **{"eval/energy_distance": [1.0, 1.2]})))
  ant, humanoid = str(tmp_path / "ant"), str(tmp_path / "humanoid")
  assert "| humanoid | gail | -eval/energy_distance | -1.100 ± 0.100 (2) |" in (
      paper_tables.compare(humanoid))
  # A rerun of the row beside the first run: each of the two rows names its file.
  os.makedirs(tmp_path / "humanoid" / "gail_rerun")
  (tmp_path / "humanoid" / "gail_rerun" / "gail_eval.json").write_text(json.dumps(
      _evaluation("gail", [0, 1], env="humanoid", **{"eval/energy_distance": [2.0, 2.2]})))
  table = paper_tables.compare(humanoid)
  assert ("| humanoid | gail (gail_eval.json) | -eval/energy_distance | -1.100 ± 0.100 (2) |"
          in table)
  assert ("| humanoid | gail (gail_rerun/gail_eval.json) | -eval/energy_distance | -2.100 ± 0.100 "
          "(2) |") in table
  assert "| ant | gail | -eval/energy_distance | -1.100 ± 0.100 (2) |" in paper_tables.compare(ant)
  # Together, the two files at one path would be taken as one row's parts: refused, named.
  with pytest.raises(ValueError, match=(
      "gail_eval.json under .*ant and .*humanoid: merge: gail on humanoid is not the row of gail "
      "on ant. Files at one path .* with a --compare of their own")):
    paper_tables.compare(ant, humanoid)
  os.makedirs(tmp_path / "empty")
  with pytest.raises(ValueError, match="no eval.json under .*empty: give the --out"):
    paper_tables.compare(ant, str(tmp_path / "empty"))
  with pytest.raises(ValueError, match="no eval.json under .*missing \\(no such directory\\)"):
    paper_tables.compare(str(tmp_path / "missing"))
  for argv, message in ((["--compare", str(tmp_path / "empty")], "--compare: no eval.json under"),
                        (["--compare", ant, humanoid], "is not the row of gail on ant")):
    monkeypatch.setattr("sys.argv", ["paper_tables.py", *argv])
    with pytest.raises(SystemExit):
      paper_tables.main()
    assert message in capsys.readouterr().err


def test_compare_draws_each_rows_final_evaluation_with_its_verdict_in_each_window(
    tmp_path, monkeypatch, capsys):
  # Humanoid rows: GAIL in both windows (Braxlines' meets the paper's 1.790 +- 0.413, blx's does
  # not), DIAYN's LGR on blx's old goals, and a DIAYN rerun beside the first run.
  rows = tmp_path / "humanoid"
  os.makedirs(rows / "diayn_rerun")
  (rows / "gail_eval.json").write_text(json.dumps(_evaluation("gail", range(3), env="humanoid", **{
      "eval/energy_distance": [2.4, 2.5, 2.6], "eval/energy_distance_braxlines": [1.6, 1.7, 1.8]})))
  diayn = {"eval/mi": [0.9, 1.0, 1.1], "eval/entropy": [6.0, 6.1, 6.2], "eval/lgr": [2.2, 2.3, 2.4]}
  (rows / "diayn_eval.json").write_text(json.dumps(
      _evaluation("diayn", range(3), goals=None, env="humanoid", **diayn)))
  (rows / "diayn_rerun" / "diayn_eval.json").write_text(json.dumps(_evaluation(
      "diayn", range(3), env="humanoid", **{"eval/mi": [0.3, 0.4, 0.5]})))
  # the rerun clipped PPO's gradient: an option's result, named as one
  (rows / "diayn_rerun" / "diayn_config.json").write_text(json.dumps({
      "format_version": runs.FORMAT_VERSION, "env": "humanoid", "objective": "diayn",
      "objective_options": {}, "ppo": {"max_grad_norm": 5, "num_evals": 40}, "seeds": [0, 1, 2]}))
  png = tmp_path / "final.png"
  drawn = paper_tables.draw_compare(str(png), str(rows))
  assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
  # a panel per metric, in the tables' order; a row in each panel that holds the metric
  assert list(drawn) == ["eval/mi", "eval/entropy", "eval/lgr", "eval/energy_distance"]
  mi_first, mi_rerun = drawn["eval/mi"]
  t_first = paper_tables.welch([0.9, 1.0, 1.1], 0.927, 0.128)
  assert mi_first == (f"diayn (diayn_eval.json)\nmeets; level with the paper "
                      f"(p {t_first[2]:.3f})")
  assert mi_rerun.split("\n")[:2] == ["diayn (diayn_rerun/diayn_eval.json)",
                                      "option max_grad_norm 5, not the original's"]
  assert mi_rerun.split("\n")[2].startswith("short; worse than the paper (p ")
  assert all("option" not in label for label in [mi_first, *drawn["eval/energy_distance"]])
  assert [len(drawn[k]) for k in ("eval/entropy", "eval/lgr")] == [1, 1]  # the rerun has MI only
  (lgr,) = drawn["eval/lgr"]  # -2.3 >= -2.313 - 0.266: meets, on other goals than the paper's
  assert lgr.split("\n")[1] == "on blx's old goals, not the paper's"
  assert lgr.split("\n")[2].startswith("meets; level with the paper (p ")
  (gail,) = drawn["eval/energy_distance"]  # lower is better: 2.5 is worse, 1.7 level
  lines = gail.split("\n")
  assert lines[0] == "gail"
  assert lines[1].startswith("blx's window: short; worse than the paper (p ")
  assert lines[2].startswith("Braxlines' window: meets; level with the paper (p ")
  # the verdicts are the table's
  table = paper_tables.compare(str(rows))
  assert "| humanoid | gail | -eval/energy_distance | -2.500 ± 0.082 (3) |" in table
  assert table.count("| **no** |") == 2  # gail in blx's window, the rerun's MI
  # from the command line, beside the table; --plot alone is refused, naming what it draws
  monkeypatch.setattr("sys.argv", ["paper_tables.py", "--compare", str(rows), "--plot", str(png)])
  paper_tables.main()
  assert f"wrote {png}" in capsys.readouterr().out
  for argv in (["--plot", str(png)], ["--paired", str(rows), str(rows), "--plot", str(png)]):
    monkeypatch.setattr("sys.argv", ["paper_tables.py", *argv])
    with pytest.raises(SystemExit):
      paper_tables.main()
    assert "--plot draws the rows of --compare" in capsys.readouterr().err
  # nothing of the paper's tables: refused, named
  os.makedirs(tmp_path / "push")
  (tmp_path / "push" / "eval.json").write_text(json.dumps(_evaluation(
      "task", range(2), env="ant_push", **{"eval/episode_score": [1.0, 2.0]})))
  with pytest.raises(ValueError, match="nothing to draw under .*push: no eval.json there holds"):
    paper_tables.draw_compare(str(png), str(tmp_path / "push"))


def test_compare_splits_an_mi_max_rows_mi_gap_into_its_entropy_and_conditional_entropy(tmp_path):
  # Ant GCRL's paper row: MI 1.218, H(s) 6.066, so its mean H(s|z) is 4.848. A row whose skills
  # cover less (H(s) 5.766, 0.3 below) and each spread a little wider (H(s|z) 4.948, 0.1 above)
  # is short by 0.3 + 0.1 of MI.
  rows = tmp_path / "ant"
  os.makedirs(rows)
  h, hz = [5.666, 5.766, 5.866], [4.848, 4.948, 5.048]
  (rows / "gcrl_eval.json").write_text(json.dumps(_evaluation("gcrl", range(3), env="ant", **{
      "eval/mi": [a - b for a, b in zip(h, hz)], "eval/entropy": h,
      "eval/conditional_entropy": hz, "eval/lgr": [2.0, 2.1, 2.2]})))
  # D-min rows, and an MI-max row from before blx recorded H(s|z), have no such line
  (rows / "gail_eval.json").write_text(json.dumps(_evaluation("gail", range(3), env="ant", **{
      "eval/energy_distance": [1.0, 1.1, 1.2]})))
  (rows / "diayn_eval.json").write_text(json.dumps(_evaluation("diayn", range(3), env="ant", **{
      "eval/mi": [1.0, 1.1, 1.2], "eval/entropy": [5.5, 5.6, 5.7]})))
  lines = paper_tables.compare(str(rows)).splitlines()
  start = lines.index(paper_tables.MI_PARTS_HEADER[0])
  assert lines[start + 2:] == paper_tables.MI_PARTS_HEADER[2:] + [
      "| ant | gcrl | 0.818 - 1.218 = -0.400 | 5.766 - 6.066 = -0.300 | 4.948 - 4.848 = +0.100 |"]
  assert paper_tables.mi_parts(json.loads((rows / "diayn_eval.json").read_text())) is None


def test_a_table_whose_runs_stopped_before_finishing_says_it_has_no_verdicts(
    tmp_path, monkeypatch, capsys):
  def run_sweep(spec, out, **kwargs):  # its runs stopped by a time limit: no eval.json
    os.makedirs(os.path.join(out, "diayn"), exist_ok=True)
    open(os.path.join(out, "summary.md"), "w").close()

  monkeypatch.setattr(sweep, "run_sweep", run_sweep)
  monkeypatch.setattr("sys.argv", ["paper_tables.py", "--objective", "diayn", "--out",
                                   str(tmp_path)])
  paper_tables.main()
  assert "mimax: no verdicts: no run there has finished (none has an eval.json)" in (
      capsys.readouterr().err)


def test_a_single_seed_gets_its_row_without_a_test():
  run = {"objective": "gcrl", "env": "ant", "per_seed": {"eval/mi": [0.556]}}
  (row,) = [r for r in paper_tables.verdicts(run) if "eval/mi" in r]
  assert "0.556 ± 0.000 (1)" in row and "n/a (1 seed)" in row and row.endswith("| **no** |")
  with pytest.raises(ValueError, match="at least 2"):
    paper_tables.welch([0.556], 1.218, 0.192)


def test_a_bad_config_is_refused_with_the_valid_keys_before_anything_trains(monkeypatch, capsys,
                                                                           tmp_path):
  assert paper_tables.ppo_config('{"num_evals": 12}', "halfcheetah") == {"num_evals": 12}
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(a))
  for config, message in (('{"num_evalz": 3}', r"unknown key\(s\) \['num_evalz'\]; valid keys"),
                          ("[1]", "a JSON object of PPO settings"),
                          ("{num_evals: 3}", "not JSON")):
    monkeypatch.setattr("sys.argv", ["paper_tables.py", "--objective", "diayn", "--config", config,
                                     "--out", str(tmp_path)])
    with pytest.raises(SystemExit):
      paper_tables.main()
    assert re.search(message, capsys.readouterr().err)
  assert not trained


@pytest.mark.parametrize("flag,text,message", [
    ("--env-edits", "{global_options.substeps: 8}", "--env-edits: not JSON"),
    ("--env-edits", "[8]", "--env-edits: a JSON object of env edits"),
    ("--options", '"spectral_norm"', "--options: a JSON object of objective options"),
    ("--options", "{spectral_norm: false}", "--options: not JSON"),
])
def test_bad_env_edits_or_options_are_named_before_anything_trains(flag, text, message,
                                                                   monkeypatch, capsys, tmp_path):
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(a))
  monkeypatch.setattr("sys.argv", ["paper_tables.py", "--objective", "diayn", flag, text,
                                   "--out", str(tmp_path)])
  with pytest.raises(SystemExit):
    paper_tables.main()
  assert message in capsys.readouterr().err
  assert not trained


def _interrupted(*args, **kwargs):  # a Ctrl-C (or a timeout's SIGINT) while a point trains
  raise KeyboardInterrupt


def test_an_interrupted_table_says_how_to_continue_and_exits_130(monkeypatch, capsys, tmp_path):
  monkeypatch.setattr(sweep, "run_sweep", _interrupted)
  monkeypatch.setattr("sys.argv", ["paper_tables.py", "--objective", "diayn",
                                   "--out", str(tmp_path)])
  with pytest.raises(SystemExit) as stop:
    paper_tables.main()
  assert stop.value.code == 130
  assert f"[paper_tables] {sweep.INTERRUPTED}" in capsys.readouterr().err


def test_the_eval_protocol_reaches_the_sweep_and_is_refused_without_eval_metrics(
    monkeypatch, capsys, tmp_path):
  trained = []

  def run_sweep(spec, out, **kwargs):
    trained.append(kwargs)
    os.makedirs(out, exist_ok=True)
    open(os.path.join(out, "summary.md"), "w").close()

  monkeypatch.setattr(sweep, "run_sweep", run_sweep)
  monkeypatch.setattr(paper_tables, "compare", lambda *a: "")
  argv = ["paper_tables.py", "--objective", "diayn", "--out", str(tmp_path),
          "--eval-protocol", "final"]
  monkeypatch.setattr("sys.argv", argv)
  with pytest.raises(SystemExit):
    paper_tables.main()
  assert ("--eval-protocol: eval_protocol 'final' sets how the metrics logged during training are "
          "evaluated, and none are logged: add --eval-metrics") in capsys.readouterr().err
  assert not trained
  monkeypatch.setattr("sys.argv", argv + ["--eval-metrics"])
  paper_tables.main()
  assert [(k["eval_metrics"], k["eval_protocol"]) for k in trained] == [(True, "final")]


def _run_dir(path, objective, env, evaluations, seeds=(0, 1, 2), budget=10e6):
  """A run directory as training leaves it: config.json and metrics.csv with ``evaluations``,
  ``[(env steps, wall seconds, {metrics.csv key: per-seed values})]`` (a seed with no value at an
  evaluation has no row there: its chunk was still in flight)."""
  path.mkdir(parents=True)
  (path / "config.json").write_text(json.dumps({
      "format_version": runs.FORMAT_VERSION, "env": env, "objective": objective,
      "objective_options": {}, "ppo": {}, "seeds": list(seeds)}))
  keys = sorted({key for _, _, values in evaluations for key in values})
  with open(path / "metrics.csv", "w", newline="") as f:
    writer = csv.DictWriter(f, ["seed", "env_steps", "total_steps", "time", *keys])
    writer.writeheader()
    for steps, wall, values in evaluations:
      for i, seed in enumerate(seeds):
        if all(i < len(v) for v in values.values()):
          writer.writerow({"seed": seed, "env_steps": steps, "total_steps": budget, "time": wall,
                           **{key: v[i] for key, v in values.items()}})
  return path


def test_paired_at_pairs_two_runs_evaluations_during_training_at_the_same_env_steps(
    tmp_path, monkeypatch, capsys):
  # Two runs of one row, evaluated every 5 M env steps; the arm's seed 2 has not reached 15 M.
  row = _run_dir(tmp_path / "row" / "objective=diayn", "diayn", "humanoid", [
      (5e6, 10.0, {"eval/mi": [0.10, 0.12, 0.11], "eval/alive_share": [0.0, 0.1, 0.0]}),
      (10e6, 20.0, {"eval/mi": [0.15, 0.14, 0.16], "eval/alive_share": [0.0, 0.0, 0.1]}),
      (15e6, 30.0, {"eval/mi": [0.2, 0.2, 0.2]})])
  arm = _run_dir(tmp_path / "arm" / "objective=diayn", "diayn", "humanoid", [
      (5e6, 10.0, {"eval/mi": [0.11, 0.12, 0.10], "eval/alive_share": [0.0, 0.0, 0.0]}),
      (10e6, 20.0, {"eval/mi": [0.30, 0.25, 0.40], "eval/alive_share": [0.2, 0.3, 0.1],
                    "loss/total": [1.0, 1.0, 1.0]}),
      (15e6, 30.0, {"eval/mi": [0.5, 0.6]})])
  file, at = paper_tables.logged_at(str(tmp_path / "arm"), 10.1e6)  # the nearest evaluation
  assert file == str(arm / "metrics.csv")
  assert at["env_steps"] == 10e6 and at["seeds"] == [0, 1, 2]
  assert at["per_seed"] == {"eval/mi": [0.30, 0.25, 0.40], "eval/alive_share": [0.2, 0.3, 0.1]}
  text = paper_tables.paired_report(str(tmp_path / "arm"), str(row / "metrics.csv"), at=10e6)
  assert "paired by seed at 10.00 M env steps per seed (evaluations during training)" in text
  ref = stats.ttest_rel([0.30, 0.25, 0.40], [0.15, 0.14, 0.16])
  assert (f"| eval/mi | 0.317 ± 0.062 | 0.150 ± 0.008 | +0.167 | {ref.statistic:+.2f} "
          f"| {ref.pvalue:.4f} |") in text
  # the share of episodes run to the end goes beside the paper's metrics, where both logged it
  assert "| eval/alive_share | 0.200 ± 0.082 | 0.033 ± 0.047 | +0.167 |" in text
  # an arm's setting that is not the original's is named from the config beside its metrics.csv
  config = json.loads((arm / "config.json").read_text())
  config["env_params"] = {"edits": {"components.agent1.observers": ["root_z_joints", "cfrc"]}}
  (arm / "config.json").write_text(json.dumps(config))
  text = paper_tables.paired_report(str(arm), str(row), at=10e6)
  assert text.splitlines()[-1] == (
      f"{arm}: settings not the original's: env components.agent1.observers ['root_z_joints', "
      "'cfrc'] (the original's: ['root_z_joints', 'cfrc', 'actuator']). An option's result, not "
      "the paper's row.")
  # 15 M is not an evaluation every seed of the arm reached; 12 M is no evaluation of either
  with pytest.raises(ValueError, match=r"no evaluation of eval/mi that every seed reached at "
                                       r"15.00 M .*it has 5.00 M, 10.00 M$"):
    paper_tables.logged_at(str(arm / "metrics.csv"), 15e6)
  with pytest.raises(ValueError, match="at 12.00 M env steps"):
    paper_tables.paired_report(str(arm), str(row), at=12e6)
  with pytest.raises(ValueError, match="2 metrics.csv files under it"):
    paper_tables.read_metrics(str(tmp_path))
  with pytest.raises(ValueError, match="neither a metrics.csv file nor a directory"):
    paper_tables.read_metrics(str(row / "config.json"))
  for argv, message in ((["--at", "10e6"], "give --paired A B with it"),
                        (["--paired", str(arm), str(row), "--at", "0"], "must be positive"),
                        (["--paired", str(arm), str(row), "--at", "12e6"], "--paired: ")):
    monkeypatch.setattr("sys.argv", ["paper_tables.py", *argv])
    with pytest.raises(SystemExit):
      paper_tables.main()
    assert message in capsys.readouterr().err


def test_paired_at_refuses_evaluations_at_different_env_steps(tmp_path):
  # evaluations 0.1 M apart both lie within 2 % of 10 M, but a pairing is at one number of steps
  a = _run_dir(tmp_path / "a", "diayn", "ant", [(10e6, 1.0, {"eval/mi": [0.3, 0.4]})], seeds=(0, 1))
  b = _run_dir(tmp_path / "b", "diayn", "ant", [(10.1e6, 1.0, {"eval/mi": [0.1, 0.2]})],
               seeds=(0, 1))
  with pytest.raises(ValueError, match="evaluated at 10,000,000 env steps, .* at 10,100,000"):
    paper_tables.paired_report(str(a), str(b), at=10e6)
  (tmp_path / "c").mkdir()
  (tmp_path / "c" / "metrics.csv").write_text("seed,env_steps,eval/mi\n0,1,0.5\n")
  with pytest.raises(ValueError, match="no config.json beside its metrics.csv"):
    paper_tables.logged_at(str(tmp_path / "c"), 1)
  # a run that logged no paper metric during training says why
  d = _run_dir(tmp_path / "d", "diayn", "ant", [(10e6, 1.0, {"loss/total": [1.0, 2.0]})],
               seeds=(0, 1))
  with pytest.raises(ValueError, match=r"it has none \(a run trained without --eval-metrics"):
    paper_tables.logged_at(str(d), 10e6)


def test_progress_reads_a_row_under_training_at_its_last_evaluation_every_seed_reached(tmp_path):
  key = "eval/energy_distance"  # HalfCheetah GAIL: the paper's 0.516 ± 0.640, lower is better
  run = _run_dir(tmp_path / "hc_gail" / "dmin" / "objective=gail", "gail", "halfcheetah", [
      (1e6, 10.0, {key: [1.0, 1.2, 1.4]}),
      # its mean, 0.5, first reaches the paper's 0.516; seed 0 is on the first mode only
      (2e6, 20.0, {key: [0.4, 0.5, 0.6], "eval/mode_share/0": [1.0, 0.5, 0.7],
                   "eval/mode_share/1": [0.0, 0.5, 0.3]}),
      (3e6, 30.0, {key: [0.9, 1.0]})])  # seed 2 not yet evaluated: not the last evaluation
  text = paper_tables.progress(str(tmp_path / "hc_gail"))
  assert f"{run}: gail on halfcheetah, under training" in text
  assert "at 2.0 M of 10.0 M env steps per seed" in text
  _, _, p = paper_tables.welch([-0.4, -0.5, -0.6], -0.516, 0.640)
  assert (f"| halfcheetah | gail | -eval/energy_distance | -0.500 ± 0.082 (3) | -0.516 ± 0.640 "
          f"| +0.07 | {p:.3f} | yes |") in text
  assert "| gail | eval/energy_distance | blx's | 0.516 | 2.00 M | 20 s |" in text
  # balances 0, 1 and 0.6 (twice the least share)
  assert "Mode balance there (1: an even split; 0: one mode): 0.53 ± 0.41; 1 of 3 seeds" in text
  (run / "eval.json").write_text("{}")
  assert "finished: its final evaluation, eval.json, is the row's verdict" in (
      paper_tables.progress(str(tmp_path)))


def test_a_row_is_named_by_the_settings_it_trained_with_but_not_for_its_return_episodes(
    tmp_path):
  from blx.training import config as ppo_config
  key = "eval/energy_distance"
  older = _run_dir(tmp_path / "older" / "dmin" / "objective=gail", "gail", "halfcheetah",
                   [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
  recorded = _run_dir(tmp_path / "recorded" / "dmin" / "objective=gail", "gail", "halfcheetah",
                      [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
  # Neither config.json sets a PPO setting. The older run records none (a segment from before
  # session 60): it evaluated with the mean action, blx's default then. The other's segment
  # records every setting it trained with: the mean action too, and a clip (say a default that
  # has moved since).
  segment = {"started": "2026-11-30T00:00:00Z", "from_env_steps": 0.0, "to_env_steps": 1e6,
             "device": "cpu", "platform": "cpu", "device_count": 1, "versions": {}}
  (older / "provenance.json").write_text(json.dumps({"segments": [segment]}))
  trained = dataclasses.asdict(ppo_config.ppo_defaults("halfcheetah", eval_actions="mean",
                                                       max_grad_norm=5.0))
  (recorded / "provenance.json").write_text(json.dumps(
      {"segments": [{**segment, "ppo": trained}]}))
  text = paper_tables.progress(str(tmp_path))
  # The clip is named from the record; the mean action is not: the return episodes' actions do
  # not touch the tables' metrics (their evaluators sample as the paper's).
  assert (f"{recorded}: settings not the original's: max_grad_norm 5.0 (the original's: None). "
          "An option's result") in text
  assert f"{older}: settings" not in text and "eval_actions" not in text


def test_a_row_trained_with_a_setting_not_the_originals_is_named_as_an_option(tmp_path):
  key = "eval/energy_distance"
  run = _run_dir(tmp_path / "clip" / "dmin" / "objective=gail", "gail", "halfcheetah",
                 [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
  plain = _run_dir(tmp_path / "plain" / "dmin" / "objective=gail", "gail", "halfcheetah",
                   [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
  config = json.loads((run / "config.json").read_text())
  # the budget and evaluation count are the run's bookkeeping; the clip is how it learns
  config["ppo"] = {"max_grad_norm": 5, "num_evals": 40, "num_timesteps": 10**6}
  (run / "config.json").write_text(json.dumps(config))
  line = (f"{run}: settings not the original's: max_grad_norm 5 (the original's: None). An "
          "option's result, not the paper's row.")
  text = paper_tables.progress(str(tmp_path))
  assert line in text and f"{plain}: settings" not in text
  for directory in (run, plain):
    (directory / "eval.json").write_text(json.dumps(
        {"objective": "gail", "env": "halfcheetah", "seeds": [0, 1, 2],
         "per_seed": {key: [0.4, 0.5, 0.6]}}))
  table = paper_tables.compare(str(tmp_path)).splitlines()
  # its budget is not a setting, but the verdict's note says it is not the paper's length
  assert table[-2:] == [line, f"{run}: trained for 1,000,000 env steps per seed, the paper's row "
                              "for 200,000,000: shorter than the paper's protocol, not its row."]
  assert sum("settings not the original's" in r for r in table) == 1
  broken = tmp_path / "broken" / "dmin" / "objective=gail"
  broken.mkdir(parents=True)
  (broken / "eval.json").write_text((run / "eval.json").read_text())
  (broken / "config.json").write_text("{not json")
  assert f"{broken}/config.json is unreadable (" in paper_tables.compare(str(tmp_path / "broken"))
  titles = paper_tables.draw_progress(str(tmp_path / "rows.png"), str(tmp_path))
  assert sorted(titles) == ["halfcheetah gail, option max_grad_norm 5; blx's window",
                            "halfcheetah gail; blx's window"]


def test_a_row_trained_for_other_steps_than_the_papers_is_named_by_its_length(tmp_path):
  key = "eval/mi"
  runs_ = {}
  # Humanoid's PPO row is 50 M env steps; the paper's MI-max rows train twice that
  for name, objective, ppo in (("twice", "diayn", {"num_timesteps": 200_000_000}),
                               ("paper", "diayn", {"num_timesteps": 100_000_000}),
                               ("unnamed", "diayn", {}),  # no length in its files: none named
                               ("recorded", "diayn", {"num_timesteps": 100_000_000}),
                               ("task", "task", {"num_timesteps": 200_000_000})):  # no paper row
    run = _run_dir(tmp_path / name / "mimax" / f"objective={objective}", objective, "humanoid",
                   [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
    config = json.loads((run / "config.json").read_text())
    config["ppo"] = ppo
    (run / "config.json").write_text(json.dumps(config))
    (run / "eval.json").write_text(json.dumps(
        {"objective": objective, "env": "humanoid", "seeds": [0, 1, 2],
         "per_seed": {key: [0.4, 0.5, 0.6]}}))
    runs_[name] = run
  # the provenance's record of what it trained with wins over config.json (a resumed run asked
  # for more steps)
  from blx.training import config as ppo_config
  trained = dataclasses.asdict(ppo_config.ppo_defaults("humanoid", num_timesteps=50_000_000))
  (runs_["recorded"] / "provenance.json").write_text(json.dumps({"segments": [{
      "started": "2026-12-05T00:00:00Z", "from_env_steps": 0.0, "to_env_steps": 1e6,
      "device": "cpu", "platform": "cpu", "device_count": 1, "versions": {}, "ppo": trained}]}))
  lines = [line for line in paper_tables.compare(str(tmp_path)).splitlines()
           if "env steps per seed" in line]
  assert lines == [
      f"{runs_['recorded']}: trained for 50,000,000 env steps per seed, the paper's row for "
      "100,000,000: shorter than the paper's protocol, not its row.",
      f"{runs_['twice']}: trained for 200,000,000 env steps per seed, the paper's row for "
      "100,000,000: longer than the paper's protocol, not its row."]
  # --paired names it too
  text = paper_tables.paired_report(str(runs_["paper"]), str(runs_["twice"]))
  assert text.splitlines()[-1] == lines[1]


def test_a_row_trained_with_an_env_edit_or_an_objective_option_is_named_as_an_option(tmp_path):
  key = "eval/mi"
  runs_ = {}
  for name, edits, options in (
      ("iterations", {"global_options.iterations": 4}, {}),  # the ant's physics: 1 by default
      ("restated", {"global_options.substeps": 10}, {"spectral_norm": True}),  # the row's own
      ("unsn", {}, {"spectral_norm": False, "num_skills": 8})):  # the row's SN; 8: the default
    run = _run_dir(tmp_path / name / "mimax" / "objective=diayn", "diayn", "ant",
                   [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
    config = json.loads((run / "config.json").read_text())
    config.update(env_params={"edits": edits} if edits else {}, objective_options=options)
    (run / "config.json").write_text(json.dumps(config))
    runs_[name] = (run, config)
  assert paper_tables.desc_off_row(runs_["iterations"][1]) == {
      "env global_options.iterations": (4, 1)}
  assert paper_tables.desc_off_row(runs_["restated"][1]) == {}
  assert paper_tables.desc_off_row(runs_["unsn"][1]) == {"objective spectral_norm": (False, True)}
  # an edit where the env has nothing, and an option the preset does not name, read "unset"
  novel = {**runs_["restated"][1], "env_params": {"edits": {"components.agent1.pos": [0, 0, 1]}},
           "objective_options": {"made_up": 1}}
  assert paper_tables.desc_off_row(novel) == {"env components.agent1.pos": ([0, 0, 1], "unset"),
                                              "objective made_up": (1, "unset")}
  # observers the desc leaves to its component (the ant's): the original's are the component's
  # defaults; the humanoid's desc names its own; an edit that restates them is no option
  ant, humanoid = ({"env": env, "objective": "diayn"} for env in ("ant", "humanoid"))
  brax = ["root_z_joints", "cfrc", "actuator"]
  for env, observers, original in ((ant, ["root_z_joints"], ["root_z_joints", "cfrc"]),
                                   (ant, ["root_z_joints", "cfrc"], None),
                                   (humanoid, ["root_z_joints"], brax), (humanoid, brax, None)):
    config = {**env, "env_params": {"edits": {"components.agent1.observers": observers}}}
    assert paper_tables.desc_off_row(config) == ({"env components.agent1.observers": (
        observers, original)} if original else {})
  lost = {**humanoid, "env_params": {"edits": {"components.agent9.observers": ["qp"]}}}
  assert paper_tables.desc_off_row(lost) == {"env components.agent9.observers": (["qp"], "unset")}
  # a humanoid row configured before its env observed Brax's parts: its desc names no observers,
  # so it was rebuilt, and trained, with the component's 45; named as blx's older env, not as an
  # option. With an edit that names observers the edit speaks for them.
  from blx import envs
  older_desc = envs.get_desc("humanoid")
  del older_desc["components"]["agent1"]["observers"]
  older = {**humanoid, "desc": older_desc}
  assert paper_tables.desc_off_row(older) == {
      "older env components.agent1.observers": (["root_z_joints"], brax)}
  assert paper_tables.options_line("row", paper_tables.desc_off_row(older)) == [
      "row: settings not the original's: older env components.agent1.observers ['root_z_joints'] "
      "(the original's: ['root_z_joints', 'cfrc', 'actuator']). Trained on blx's older env, not "
      "the paper's row as blx builds it now."]
  assert paper_tables.desc_off_row({**humanoid, "desc": envs.get_desc("humanoid")}) == {}
  edited = {**older, "env_params": {"edits": {"components.agent1.observers": brax}}}
  assert paper_tables.desc_off_row(edited) == {}
  text = paper_tables.progress(str(tmp_path))
  assert (f"{runs_['iterations'][0]}: settings not the original's: env global_options.iterations "
          "4 (the original's: 1). An option's result, not the paper's row.") in text
  assert (f"{runs_['unsn'][0]}: settings not the original's: objective spectral_norm False (the "
          "original's: True).") in text
  assert f"{runs_['restated'][0]}: settings" not in text
  titles = paper_tables.draw_progress(str(tmp_path / "rows.png"), str(tmp_path))
  assert sorted(titles) == [
      "ant diayn, option env global_options.iterations 4, under training; blx's window",
      "ant diayn, option objective spectral_norm False, under training; blx's window",
      "ant diayn, under training; blx's window"]
  # the older humanoid row's panels say so, not as an option
  run = _run_dir(tmp_path / "older" / "diayn", "diayn", "humanoid",
                 [(1e6, 10.0, {key: [0.4, 0.5, 0.6]})])
  (run / "config.json").write_text(json.dumps({**json.loads((run / "config.json").read_text()),
                                               "desc": older_desc}))
  assert paper_tables.draw_progress(str(tmp_path / "older.png"), str(tmp_path / "older"))[0] == (
      "humanoid diayn, older env components.agent1.observers ['root_z_joints'], under training; "
      "blx's window")


def test_runs_drawn_together_share_a_window_and_a_range_per_metric(tmp_path, monkeypatch):
  # One run logged Braxlines' window for MI, the other (older) blx's alone: drawn together, both
  # are drawn in blx's, and their MI panels share one range of values, so the rows compare.
  _run_dir(tmp_path / "newer" / "mimax" / "objective=diayn", "diayn", "humanoid", [
      (1e6, 10.0, {"eval/mi": [0.7, 0.9], "eval/mi_braxlines": [0.2, 0.3]})], seeds=(0, 1))
  _run_dir(tmp_path / "older" / "mimax" / "objective=diayn", "diayn", "humanoid",
           [(1e6, 10.0, {"eval/mi": [0.1, 0.2]})], seeds=(0, 1))
  import matplotlib.pyplot as plt
  figures = []
  monkeypatch.setattr(plt, "close", figures.append)
  png = str(tmp_path / "rows.png")
  assert paper_tables.draw_progress(png, str(tmp_path)) == [
      "humanoid diayn, under training; blx's window"] * 2
  (newer_ax, older_ax), = [[a for a in f.axes if a.get_title()] for f in figures]
  assert newer_ax.get_ylim() == older_ax.get_ylim()
  assert [min(newer_ax.lines[0].get_ydata()), min(older_ax.lines[0].get_ydata())] == pytest.approx(
      [0.8, 0.15])
  # beside another row's run alone, the newer run is drawn in Braxlines' window, where the paper's
  # numbers were taken, with its own range of values
  _run_dir(tmp_path / "other" / "mimax" / "objective=diayn", "diayn", "ant",
           [(1e6, 10.0, {"eval/mi": [0.1, 0.2]})], seeds=(0, 1))
  figures.clear()
  assert paper_tables.draw_progress(png, str(tmp_path / "newer"), str(tmp_path / "other")) == [
      "humanoid diayn, under training; Braxlines' window",
      "ant diayn, under training; blx's window"]
  (newer_ax, other_ax), = [[a for a in f.axes if a.get_title()] for f in figures]
  assert newer_ax.get_ylim() != other_ax.get_ylim()


def test_a_finished_runs_final_evaluation_is_read_for_its_marker(tmp_path):
  run = _run_dir(tmp_path / "run", "gcrl", "ant", [(1e6, 10.0, {"eval/mi": [0.4, 0.5, 0.6]})])
  assert paper_tables.logged_run(str(run / "metrics.csv"))[3] is None  # not finished
  assert paper_tables.final_point(None, "eval/mi", "blx's window") == []
  evaluation = {"objective": "gcrl", "env": "ant", "seeds": [0, 1, 2],
                "per_seed": {"eval/mi": [1.0, 1.1, 1.2], "eval/mi_braxlines": [0.9, 1.0, 1.1],
                             "eval/lgr": [2.0, 2.1, 2.2]}}
  (run / "eval.json").write_text(json.dumps(evaluation))
  assert paper_tables.logged_run(str(run / "metrics.csv"))[3] == str(run / "eval.json")
  assert paper_tables.final_point(evaluation, "eval/mi", "blx's window") == [1.0, 1.1, 1.2]
  assert paper_tables.final_point(evaluation, "eval/mi", "Braxlines' window") == [0.9, 1.0, 1.1]
  # an LGR on blx's old goals is no point beside the paper's; on the paper's goals it is
  assert paper_tables.final_point(evaluation, "eval/lgr", "blx's window") == []
  evaluation["evaluated_on"] = {"lgr_goals": "braxlines"}
  assert paper_tables.final_point(evaluation, "eval/lgr", "blx's window") == [2.0, 2.1, 2.2]
  # a committed row's final evaluation is NAME_eval.json beside its NAME_metrics.csv
  (tmp_path / "gcrl_metrics.csv").write_text((run / "metrics.csv").read_text())
  assert paper_tables.logged_run(str(tmp_path / "gcrl_metrics.csv"))[3] is None
  (tmp_path / "gcrl_eval.json").write_text(json.dumps(evaluation))
  assert paper_tables.logged_run(str(tmp_path / "gcrl_metrics.csv"))[3] == str(
      tmp_path / "gcrl_eval.json")


def test_progress_names_runs_it_cannot_read_against_the_paper(tmp_path, monkeypatch, capsys):
  _run_dir(tmp_path / "push", "task", "ant_push", [(1e6, 10.0, {"eval/episode_score": [1, 2]})],
           seeds=(0, 1))
  _run_dir(tmp_path / "plain", "diayn", "ant", [(1e6, 10.0, {"loss/total": [1, 2]})],
           seeds=(0, 1))
  (tmp_path / "loose").mkdir()
  (tmp_path / "loose" / "metrics.csv").write_text("seed,env_steps\n0,1\n")
  (tmp_path / "odd").mkdir()
  (tmp_path / "odd" / "metrics.csv").write_text("seed,env_steps\n0,1\n")
  (tmp_path / "odd" / "config.json").write_text("[1, 2]")
  text = paper_tables.progress(str(tmp_path))
  assert "odd: passed over: " in text and "not a blx run config (it names no env and" in text
  assert "task on ant_push has no row in the paper's tables" in text
  assert "loose: passed over: no config.json beside its metrics.csv" in text
  assert ("no evaluation with the paper's metrics in its metrics.csv (train with --eval-metrics)"
          in text)
  with pytest.raises(ValueError, match="no metrics.csv under .*empty"):
    paper_tables.progress(str(tmp_path / "empty"))
  for argv, message in (
      (["--progress", str(tmp_path / "empty")], "--progress: no metrics.csv under"),
      (["--progress", str(tmp_path), "--compare", str(tmp_path)], "give one")):
    monkeypatch.setattr("sys.argv", ["paper_tables.py", *argv])
    with pytest.raises(SystemExit):
      paper_tables.main()
    assert message in capsys.readouterr().err


def test_progress_reads_committed_rows_and_draws_each_against_the_paper(tmp_path, monkeypatch):
  # A committed row (as under benchmarks/paper/): NAME_metrics.csv beside NAME_config.json and
  # NAME_eval.json; MI-max logs Braxlines' window for MI and H(s), not for LGR.
  rows = tmp_path / "brax_halfcheetah"
  run = _run_dir(rows / "tmp", "diayn", "halfcheetah", [
      (1e6, 10.0, {"eval/mi": [0.5, 0.7], "eval/mi_braxlines": [0.6, 0.8],
                   "eval/entropy": [5.0, 5.2], "eval/entropy_braxlines": [5.1, 5.3],
                   "eval/lgr": [2.0, 2.2]})], seeds=(0, 1))
  for name in ("config.json", "metrics.csv"):
    (run / name).rename(rows / f"diayn_{name}")
  (rows / "diayn_eval.json").write_text("{}")
  _run_dir(tmp_path / "hc_gail" / "dmin" / "objective=gail", "gail", "halfcheetah",
           [(1e6, 10.0, {"eval/energy_distance": [0.4, 0.6]})], seeds=(0, 1))
  _run_dir(tmp_path / "push", "task", "ant_push", [(1e6, 10.0, {"eval/episode_score": [1, 2]})],
           seeds=(0, 1))
  text = paper_tables.progress(str(tmp_path))
  assert f"{rows / 'diayn'}: diayn on halfcheetah, finished" in text
  assert "| halfcheetah | diayn | eval/mi (Braxlines' window) | 0.700 ± 0.100 (2) |" in text
  # Its LGR was evaluated on other goals than the paper's: no provenance says otherwise; then a
  # segment that drew the partitionable goals up to 1 M steps, and one that drew the paper's.
  note = "| -eval/lgr" + paper_tables.OTHER_GOALS + " | -2.100 ± 0.100 (2) |"
  assert note in text
  from blx.experiments import runs
  segment = runs.Segment("2026-11-27T00:00:00Z", 0.0, 5e5, "H200", "gpu", 1, {},
                         lgr_goals="braxlines")
  for goals, named in (("partitionable", True), ("braxlines", False)):
    runs._write_provenance(str(rows), [segment, dataclasses.replace(
        segment, from_env_steps=5e5, to_env_steps=1e6, lgr_goals=goals)])
    os.replace(rows / runs.PROVENANCE, rows / "diayn_provenance.json")
    assert (note in paper_tables.progress(str(rows))) == named
  assert note not in paper_tables.progress(str(tmp_path / "hc_gail"))  # D-min: no LGR
  # one committed row of a directory that holds several: its NAME_metrics.csv alone
  (rows / "gail_metrics.csv").write_text((tmp_path / "hc_gail" / "dmin" / "objective=gail" /
                                          "metrics.csv").read_text())
  assert [name for name, *_ in paper_tables.logged(str(rows))] == [
      str(rows / "diayn"), str(rows / "gail")]
  assert [name for name, *_ in paper_tables.logged(str(rows / "diayn_metrics.csv"))] == [
      str(rows / "diayn")]
  with pytest.raises(ValueError, match="diayn_eval.json: neither a metrics.csv file nor a "
                                       "directory holding one"):
    paper_tables.logged(str(rows / "diayn_eval.json"))
  (rows / "gail_metrics.csv").unlink()
  png = tmp_path / "progress.png"
  titles = paper_tables.draw_progress(str(png), str(tmp_path))
  assert titles == ["halfcheetah diayn; Braxlines' window"] * 2 + [
      "halfcheetah diayn; blx's window", "halfcheetah gail, under training; blx's window"]
  assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
  # an LGR on blx's old goals is drawn faded, and its panel says so
  runs._write_provenance(str(rows), [dataclasses.replace(segment, to_env_steps=1e6,
                                                         lgr_goals=None)])
  os.replace(rows / runs.PROVENANCE, rows / "diayn_provenance.json")
  assert paper_tables.draw_progress(str(png), str(tmp_path))[2] == (
      "halfcheetah diayn; blx's window; faded: blx's old goals, not the paper's")
  with pytest.raises(ValueError, match="nothing to draw under .*push"):
    paper_tables.draw_progress(str(png), str(tmp_path / "push"))
  monkeypatch.setattr("sys.argv", ["paper_tables.py", "--plot", str(png)])
  with pytest.raises(SystemExit):
    paper_tables.main()


def test_the_rows_said_to_draw_latents_are_those_whose_presets_do():
  from blx import metrics, objectives
  mimax = {objective for rows in paper_tables.PAPER.values()
           for objective, keys in rows.items() if "eval/mi" in keys}
  drawn = set()
  for name in mimax:
    options = {"obs_indices": (0, 1)} if "obs_indices" in objectives.options_of(name) else {}
    if metrics.draws_latents(objectives.make(name, **options)):
      drawn.add(name)
  assert drawn == paper_tables.DRAWN_LATENTS and mimax - drawn == {"diayn", "diayn_full"}


def test_the_progress_caption_says_only_what_holds_for_the_rows_drawn():
  skills = paper_tables.progress_caption({("humanoid", "diayn")})
  drawn = paper_tables.progress_caption({("humanoid", "cdiayn"), ("ant", "gcrl")})
  dmin = paper_tables.progress_caption({("halfcheetah", "gail")})
  assert "(4 episodes of each skill)" in skills and "10 where the curves have 4" in skills
  assert "MI higher" in skills and "MI lower" not in skills
  assert "(4 latents drawn from the prior, 4 episodes each)" in drawn
  assert "MI lower" in drawn and "MI higher" not in drawn
  assert "4 latents cover less than 10" in drawn
  assert "(4 episodes)" in dmin and "MI" not in dmin
  every = paper_tables.progress_caption({("ant", "diayn"), ("ant", "cdiayn"), ("ant", "airl")})
  assert ("(4 episodes of each skill; 4 latents drawn from the prior, 4 episodes each; 4 episodes)"
          in every and "MI higher" in every and "MI lower" in every)
