"""benchmarks/ablations.py: arms that differ from the paper's row in one setting, their curves and
their comparison."""

import csv
import dataclasses
import inspect
import json
import os
import re

import pytest

from blx.experiments import sweep
from blx.objectives import presets
from tests.experiments import load_benchmark

ablations = load_benchmark("ablations")


def _default(objective, option):
  return inspect.signature(presets._preset(objective)).parameters[option].default


_STUDY_ENVS = [(name, env) for name, study in sorted(ablations.STUDIES.items())
               if study.family != "task" for env in (study.envs or ("ant", "humanoid"))]


@pytest.mark.parametrize("name,env", _STUDY_ENVS)
def test_arms_differ_from_the_paper_row_in_the_studied_option_only(name, env):
  study = ablations.STUDIES[name]
  row = ablations.paper_tables.specs(10, env=env)[study.family]
  points = sweep.expand(ablations.spec(study, env, 10))
  assert len(points) == len(study.objectives) * len(study.values)
  other = "env_params" if study.group == "options" else "options"
  other_field = "env_params" if study.group == "options" else "objective_options"
  for objective in study.objectives:
    arms = [s for _, s in points if s.objective == objective]
    assert [study.value(s) for s in arms] == list(study.values)
    # The first arm is the paper's row: its value is the row's, or the objective's (or env's)
    # default.
    default = ({} if study.group == "env_params" else _default(objective, study.option))
    assert study.values[0] == row[study.group].get(study.option, default)
    for arm in arms:
      rest = {k: v for k, v in study.settings(arm).items() if k != study.option}
      assert rest == {k: v for k, v in row[study.group].items() if k != study.option}
      assert getattr(arm, other_field) == row[other]
      assert (arm.env, arm.seeds) == (env, tuple(range(10)))
      assert arm.ppo == {"num_timesteps": row["steps"]}


@pytest.mark.parametrize("name,scene,steps", [("push_scale", "ant_push", 30_000_000),
                                               ("legs", "pro_ant_run", 300_000_000)])
def test_the_composer_sweeps_vary_their_scenes_parameter_on_the_originals_budget(name, scene,
                                                                                 steps):
  # The original's sweeps at the paper's commit: ant_push_sweep.py trains the ant's PPO row (30 M
  # steps), ant_run_morphology_sweep.py the row x 10.
  from blx.envs import descs, registry
  study = ablations.STUDIES[name]
  points = sweep.expand(ablations.spec(study, "ant", 10))
  assert [study.value(s) for _, s in points] == list(study.values)
  # An episode that ends early (the body fell or flipped) sums fewer per-step scores, all negative,
  # so its score looks better: the length is tabulated and drawn beside it; and a seed's evaluation
  # is one episode, so the training reward is too.
  assert study.metrics == ("eval/episode_score", "eval/episode_length", "train/env_reward")
  assert all(m in ablations.LABELS for m in study.metrics)
  registered = inspect.signature(getattr(descs, scene)).parameters[study.option].default
  assert study.values[0] == registered  # the first arm is the registered env
  for _, arm in points:
    assert (arm.env, arm.objective, arm.seeds) == (scene, "task", tuple(range(10)))
    assert arm.env_params == {**(study.scene_params or {}), study.option: study.value(arm)}
    assert arm.objective_options == {}
    assert arm.ppo == {"num_timesteps": steps}
  desc = registry.get_desc(scene, **points[1][1].env_params)
  assert points[1][1].env_params[study.option] != registered and desc != registry.get_desc(scene)
  assert ablations.budget_line(study, ablations.spec(study, "ant", 2)) == (
      f"Env steps per seed: {steps / 1e6:g} M (the original's).")
  assert ablations.budget_line(study, ablations.spec(study, "ant", 2, steps=6_000_000)) == (
      f"Env steps per seed: 6 M; the original's: {steps / 1e6:g} M (a shorter budget).")
  # the steps the arms reached, where PPO's whole iterations took them past the budget asked
  assert ablations.budget_line(study, ablations.spec(study, "ant", 2, steps=6_000_000),
                               6_881_280.0) == (
      f"Env steps per seed: 6 M; the original's: {steps / 1e6:g} M (a shorter budget); 6.88 M "
      "trained (whole PPO iterations per evaluation chunk).")
  assert ablations.budget_line(study, ablations.spec(study, "ant", 2), float(steps)) == (
      f"Env steps per seed: {steps / 1e6:g} M (the original's).")
  with pytest.raises(ValueError, match=r"defined for \['ant'\]"):
    ablations.spec(study, "humanoid", 2)


def test_the_step_studies_keep_the_cheetahs_env_step_and_iterations():
  from blx.envs import registry
  fast = ablations.CHEETAH_FAST_STEP
  base = registry.get_desc("halfcheetah")["global_options"]
  edited = registry.get_desc("halfcheetah", edits=fast)["global_options"]
  assert edited["timestep"] * edited["substeps"] == pytest.approx(
      base["timestep"] * base["substeps"])  # the same 50 ms control step
  assert (edited["substeps"], edited["iterations"]) == (8, base["iterations"])
  assert base["substeps"] == 16
  with pytest.raises(ValueError, match=r"defined for \['halfcheetah'\]"):
    ablations.spec(ablations.STUDIES["step_diayn"], "ant", 2)


def test_legs_and_legs_original_are_the_leg_count_sweep_at_blxs_step_and_at_the_originals():
  from blx.envs import registry
  coarse, fine = (ablations.STUDIES[name] for name in ("legs", "legs_original"))
  assert (fine.values, fine.labels, fine.claim, fine.paper) == (
      coarse.values, coarse.labels, coarse.claim, coarse.paper)
  plain = dict(sweep.expand(ablations.spec(coarse, "ant", 2)))
  points = sweep.expand(ablations.spec(fine, "ant", 2))
  assert [name for name, _ in points] == list(plain)  # the same arms, at another step
  for name, arm in points:
    assert arm.env_params == {**plain[name].env_params, "step": "original"}
    assert plain[name].env_params["step"] == "blx"  # each names its step, not the env's default
    assert arm.ppo == plain[name].ppo == {"num_timesteps": 300_000_000}
    for run, want in ((arm, (0.00125, 16)), (plain[name], (0.005, 4))):
      options = registry.get_desc(run.env, **run.env_params)["global_options"]
      assert (options["timestep"], options["substeps"]) == want
  # the reports' headers and figure titles say so
  assert fine.claim_line == coarse.claim_line.replace("'blx'", "'original'")
  assert coarse.claim_line.endswith("; every arm: pro_ant_run(step='blx')")


def test_the_legs_step_study_runs_three_legs_at_blxs_step_and_at_the_originals():
  from blx.envs import registry
  study = ablations.STUDIES["legs_step"]
  points = sweep.expand(ablations.spec(study, "ant", 2))
  descs = [registry.get_desc(arm.env, **arm.env_params) for _, arm in points]
  assert [arm.env for _, arm in points] == ["pro_ant_run"] * 2
  assert [d["components"]["agent1"]["component_params"]["num_legs"] for d in descs] == [3, 3]
  steps = [(d["global_options"]["timestep"], d["global_options"]["substeps"]) for d in descs]
  assert steps[0] == (0.005, 4)  # blx's step, whatever the env's default
  assert steps[1] == (0.00125, 16)  # the original's pro_ant_run: dt 0.02 in 16 substeps
  assert steps[0][0] * steps[0][1] == pytest.approx(steps[1][0] * steps[1][1]) == 0.02
  # the arms are the env's two named steps; the header says the edits start from blx's
  for desc, name in zip(descs, ("blx", "original")):
    assert desc == registry.get_desc("pro_ant_run", num_legs=3, step=name)
  assert study.claim_line.endswith("every arm: pro_ant_run(step='blx') before its edits")
  with pytest.raises(ValueError, match=r"defined for \['ant'\]"):
    ablations.spec(study, "humanoid", 2)


def test_curve_is_the_mean_and_std_over_seeds_where_every_seed_was_evaluated():
  values = {(0, 10): "1.0", (1, 10): "3.0", (0, 20): "2.0", (1, 20): "nan",  # seed 1 diverged
            (0, 30): "4.0", (1, 30): "6.0", (0, 40): "5.0", (1, 40): ""}  # seed 1 not yet at 40
  rows = [{"seed": seed, "env_steps": step, "eval/mi": v} for (seed, step), v in values.items()]
  steps, mean, std = ablations.curve(rows, "eval/mi")
  assert steps == [10.0, 30.0] and mean == [2.0, 5.0] and std == [1.0, 1.0]


def _arm(objective, values):
  return {"objective": objective, "per_seed": {"eval/mi": values}}


def test_compare_tests_each_arm_against_the_first_arm_of_its_objective():
  rows = ablations.compare({
      "on": _arm("diayn", [1.0, 1.1, 0.9, 1.05, 0.95]),
      "same": _arm("diayn", [1.0, 1.1, 0.9, 1.05, 0.95]),
      "off": _arm("diayn", [0.5, 0.6, 0.4, 0.55, 0.45]),
  }, ("eval/mi",))
  on, same, off = rows[2:]
  assert on.endswith("|  |  |")  # the reference arm is not tested against itself
  assert "| +0.00 | 1.000 |" in same
  t, p = off.strip("| ").split(" | ")[-2:]
  assert float(t) < -5 and p == "< 0.001"  # not "0.000"
  assert "0.500 ± 0.071 (5)" in off


def test_welch_cells_say_no_spread_where_both_arms_are_constant_not_nan():
  # every episode of both arms ran its 1,000 steps: the t-test is undefined, not a number
  assert ablations.welch_cells([1000.0] * 10, [1000.0] * 10) == ["", "equal, no spread"]
  assert ablations.welch_cells([999.0] * 10, [1000.0] * 10) == ["", "no spread"]
  assert ablations.welch_cells([999.0, 1000.0], [1000.0] * 10)[1] == "0.500"  # one side spreads
  assert ablations.welch_cells([1.0], [1.0, 2.0]) == ["", ""]


def test_report_draws_and_tabulates_the_evaluated_arms(tmp_path):
  study = ablations.STUDIES["sn_diayn"]
  spec = ablations.spec(study, "ant", 2)
  for (name, _), shift in zip(sweep.expand(spec), (0.0, -0.5)):
    d = tmp_path / name
    d.mkdir()
    (d / "eval.json").write_text(json.dumps(_arm("diayn", [1.0 + shift, 1.2 + shift])))
    with open(d / "metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "eval/mi", "eval/entropy"])
      w.writeheader()
      for step in (1e6, 2e6):
        for seed in (0, 1):
          w.writerow({"seed": seed, "env_steps": step, "eval/mi": step / 2e6 + shift + seed / 5,
                      "eval/entropy": 5.0})
  table = ablations.report("sn_diayn", study, str(tmp_path), spec)
  assert "spectral_norm=True | eval/mi | 1.100 ± 0.100 (2)" in table
  assert "spectral_norm=False | eval/mi | 0.600 ± 0.100 (2)" in table
  assert os.path.getsize(tmp_path / "curves.png") > 10_000
  assert table in (tmp_path / "ablation.md").read_text()


def test_an_env_edit_axis_names_its_arms_without_braces_or_quotes():
  spec = ablations.spec(ablations.STUDIES["step_gail"], "halfcheetah", 2, steps=1000)
  names = [name for name, _ in sweep.expand(spec)]
  assert names == ["edits=none",
                   "edits=global_options.timestep=0.00625,global_options.substeps=8"]


def test_legend_entries_are_the_studys_labels_where_given_and_the_point_names_otherwise():
  step = ablations.STUDIES["step_gail"]
  points = sweep.expand(ablations.spec(step, "halfcheetah", 2, steps=1000))
  assert [step.label(n, s) for n, s in points] == ["blx's step: 16 x 3.125 ms", "8 x 6.25 ms"]
  assert step.claim_line.startswith("tested (not a claim of the paper): ")
  gp = ablations.STUDIES["gp"]
  points = sweep.expand(ablations.spec(gp, "ant", 2, steps=1000))
  assert [gp.label(n, s) for n, s in points][:4] == [
      "airl, no penalty (the paper's row)", "airl, penalty weight 1", "airl, penalty weight 10",
      "gail, no penalty (the paper's row)"]
  assert gp.claim_line.startswith("the paper: ")
  sn = ablations.STUDIES["sn_diayn"]
  points = sweep.expand(ablations.spec(sn, "ant", 2, steps=1000))
  assert [sn.label(n, s) for n, s in points] == ["spectral_norm=True", "spectral_norm=False"]


def test_a_studys_arms_of_one_value_share_a_colour_and_its_objectives_a_line_style(tmp_path,
                                                                                    monkeypatch):
  import matplotlib.axes
  drawn, plot = {}, matplotlib.axes.Axes.plot
  monkeypatch.setattr(matplotlib.axes.Axes, "plot", lambda self, *a, **k: drawn.update(
      {k.get("label"): (k.get("color"), a[2] if len(a) > 2 else None)}) or plot(self, *a, **k))
  study = ablations.STUDIES["gp"]
  spec = ablations.spec(study, "ant", 2, steps=2000, config={"num_evals": 2})
  for name, _ in sweep.expand(spec):
    if "weight=10.0" in name and "airl" in name:
      continue  # an arm not run yet: the others keep their value's colour
    (tmp_path / name).mkdir()
    _write_metrics(tmp_path / name / "metrics.csv", {(0, 2000): 1.0, (1, 2000): 1.2},
                   key="eval/energy_distance")
  ablations.report("gp", study, str(tmp_path), spec)
  airl = [drawn[f"airl, {v} (unfinished)"] for v in study.labels if not v.endswith("10")]
  gail = [drawn[f"gail, {v} (unfinished)"] for v in study.labels]
  assert [c for c, _ in gail] == ["C0", "C1", "C2"]
  assert [c for c, _ in airl] == ["C0", "C1"]
  assert {line for _, line in airl} == {"-"} and {line for _, line in gail} == {"--"}


def test_an_arm_of_one_evaluation_is_drawn_as_a_point_with_its_spread(tmp_path, monkeypatch):
  import matplotlib.axes
  drawn, bars, plot, errorbar = {}, [], matplotlib.axes.Axes.plot, matplotlib.axes.Axes.errorbar
  monkeypatch.setattr(matplotlib.axes.Axes, "plot", lambda self, *a, **k: drawn.update(
      {k.get("label"): (list(a[0]), k.get("marker"))}) or plot(self, *a, **k))
  monkeypatch.setattr(matplotlib.axes.Axes, "errorbar", lambda self, *a, **k: bars.append(
      (list(a[0]), list(a[1]), list(k["yerr"]))) or errorbar(self, *a, **k))
  study = ablations.STUDIES["sn_diayn"]
  spec = ablations.spec(study, "ant", 2, steps=4000, config={"num_evals": 2})
  (first, _), (second, _) = sweep.expand(spec)
  for name, values in ((first, {(0, 2000): 1.0, (1, 2000): 1.2, (0, 4000): 1.5, (1, 4000): 1.7}),
                       (second, {(0, 2000): 0.5, (1, 2000): 0.9})):  # the second: one evaluation
    (tmp_path / name).mkdir()
    _write_metrics(tmp_path / name / "metrics.csv", values)
  ablations.report("sn_diayn", study, str(tmp_path), spec)
  assert drawn["spectral_norm=True (unfinished)"] == ([0.002, 0.004], None)  # a line
  assert drawn["spectral_norm=False (unfinished)"] == ([0.002], "o")  # a point
  assert ([0.002], [0.7], [0.2]) in [(x, [round(v, 6) for v in m], [round(v, 6) for v in d])
                                     for x, m, d in bars]  # and its std over seeds


def _write_metrics(path, values, key="eval/mi"):
  """A metrics.csv with ``values[(seed, env steps)]`` of ``key``."""
  with open(path, "w", newline="") as f:
    w = csv.DictWriter(f, ["seed", "env_steps", key])
    w.writeheader()
    for (seed, step), v in values.items():
      w.writerow({"seed": seed, "env_steps": step, key: v})


def test_time_to_is_the_wall_time_at_which_each_arm_first_reaches_the_first_arms_last_mean():
  def rows(points):  # {(seed, env steps): value}; wall time 10 s per million steps, x cost
    return [{"seed": seed, "env_steps": step, "time": step / 1e5 * cost, "eval/lgr": v,
             "eval/episode_score": -v * 100, "eval/episode_length": 1000.0}
            for (seed, step, cost), v in points.items()]
  m = 1e6
  # the first arm (cheap) ends at 2.0; the second (3x the cost per step) is at 1.9 by 20 M; the
  # third never gets there
  cheap = rows({(0, 10 * m, 1): 3.0, (1, 10 * m, 1): 3.2, (0, 30 * m, 1): 1.9, (1, 30 * m, 1): 2.1})
  dear = rows({(0, 10 * m, 3): 2.5, (1, 10 * m, 3): 2.5, (0, 20 * m, 3): 1.8, (1, 20 * m, 3): 2.0})
  stuck = rows({(0, 10 * m, 1): 4.0, (1, 10 * m, 1): 4.0, (0, 30 * m, 1): 2.5, (1, 30 * m, 1): 2.5})
  table = ablations.time_to({"cheap": ("task", cheap), "dear": ("task", dear),
                             "stuck": ("task", stuck)},
                            ("eval/lgr", "eval/episode_score", "eval/episode_length"))
  cells = [[c.strip() for c in r.split("|")[1:-1]] for r in table[2:]]
  assert cells == [
      ["cheap", "eval/lgr", "2.000", "30.00 M", "300 s"],  # lower is better
      ["dear", "eval/lgr", "2.000", "20.00 M", "600 s"],
      ["stuck", "eval/lgr", "2.000", "not reached", ""],
      ["cheap", "eval/episode_score", "-200.000", "30.00 M", "300 s"],  # higher is better
      ["dear", "eval/episode_score", "-200.000", "20.00 M", "600 s"],
      ["stuck", "eval/episode_score", "-200.000", "not reached", ""]]  # the length has no target


def test_time_to_paper_reaches_the_papers_mean_on_the_curve_of_braxlines_window():
  m = 1e6

  def rows(points):  # {(seed, env steps): (blx's window, Braxlines' or None)}; 10 s per M steps
    return [{"seed": seed, "env_steps": step, "time": step / 1e5, "eval/energy_distance": blx,
             **({"eval/energy_distance_braxlines": brax} if brax is not None else {})}
            for (seed, step), (blx, brax) in points.items()]
  # The paper's Ant GAIL is 0.802, its AIRL 2.588 (paper_tables.PAPER). The first arm reaches
  # 0.802 in Braxlines' window at 20 M and never in blx's; the second logged blx's window alone
  # and reaches it there at 10 M; the AIRL arm never gets there; "task" has no paper value.
  gail = rows({(0, 10 * m): (2.0, 1.0), (1, 10 * m): (2.0, 0.9),
               (0, 20 * m): (1.9, 0.8), (1, 20 * m): (1.9, 0.7)})
  older = rows({(0, 10 * m): (0.8, None), (1, 10 * m): (0.7, None)})
  airl = rows({(0, 10 * m): (3.0, 3.0), (1, 10 * m): (2.9, 2.8)})
  task = rows({(0, 10 * m): (0.1, 0.1), (1, 10 * m): (0.1, 0.1)})
  table = ablations.time_to_paper({"gail": ("gail", gail), "older": ("gail", older),
                                   "airl": ("airl", airl), "task": ("task", task)}, "ant",
                                  ("eval/energy_distance", "eval/mode_balance"))
  cells = [[c.strip() for c in r.split("|")[1:-1]] for r in table[2:]]
  assert cells == [
      ["gail", "eval/energy_distance", "Braxlines'", "0.802", "20.00 M", "200 s"],
      ["older", "eval/energy_distance", "blx's", "0.802", "10.00 M", "100 s"],
      ["airl", "eval/energy_distance", "Braxlines'", "2.588", "not reached", ""]]
  # Nothing the paper reports, nothing to write; a lower-is-better value is read back un-negated.
  assert ablations.time_to_paper({"task": ("task", task)}, "ant", ("eval/energy_distance",)) == []
  assert ablations.paper_value("humanoid", "gail", "eval/energy_distance") == 1.790
  assert ablations.paper_value("ant", "diayn", "eval/mi") == 1.115


def test_against_tests_each_arms_last_evaluation_against_the_reference_at_the_same_steps(tmp_path):
  arm = [{"seed": s, "env_steps": step, "eval/mi": v}
         for (s, step), v in {(0, 10): 0.1, (1, 10): 0.3, (0, 20): 1.0, (1, 20): 1.2}.items()]
  # The reference ran on past the arm: only its evaluation at 20 counts, not its last (at 40).
  reference = [{"seed": s, "env_steps": step, "eval/mi": v}
               for (s, step), v in {(0, 20): 0.4, (1, 20): 0.6, (2, 20): 0.5,
                                    (0, 40): 9.0, (1, 40): 9.0, (2, 40): 9.0}.items()]
  rows = ablations.against({"arm": arm}, "the row", reference, ("eval/mi", "eval/lgr"))
  assert len(rows) == 3  # the header, its rule, and eval/mi only: neither logs eval/lgr
  cells = rows[2].strip("| ").split(" | ")
  assert cells[:5] == ["arm", "eval/mi", "0.00 M", "1.100 ± 0.100 (2)", "0.500 ± 0.082 (3)"]
  from scipy import stats
  want = stats.ttest_ind([1.0, 1.2], [0.4, 0.6, 0.5], equal_var=False)
  assert float(cells[5]) == pytest.approx(want.statistic, abs=0.01)
  assert float(cells[6]) == pytest.approx(want.pvalue, abs=0.001)
  # A reference on another grid: the last steps both were evaluated at, the arm's last named.
  grid = [{"seed": s, "env_steps": step, "eval/mi": 0.5} for s in (0, 1) for step in (10, 15)]
  cells = ablations.against({"arm": [dict(r, env_steps=r["env_steps"] * 1e5) for r in arm]},
                            "the row", [dict(r, env_steps=r["env_steps"] * 1e5) for r in grid],
                            ("eval/mi",))[2].strip("| ").split(" | ")
  assert cells[2:5] == ["1.00 M (the arm's last: 2.00 M)", "0.200 ± 0.100 (2)",
                        "0.500 ± 0.000 (2)"]
  # A reference never evaluated at any of the arm's steps is said so, with its nearest steps.
  off_grid = [dict(r, env_steps=r["env_steps"] + 5e6) for r in reference]
  row = ablations.against({"arm": arm}, "the row", off_grid, ("eval/mi",))[2]
  assert "no evaluation at 0.00 M (nearest: 5.00 M, 5.00 M)" in row


def test_read_reference_takes_a_run_directory_or_its_csv_and_refuses_one_without_the_metrics(
    tmp_path):
  _write_metrics(tmp_path / "metrics.csv", {(0, 10): 0.5})
  ref = ablations.read_reference("row", str(tmp_path), ("eval/mi",))
  assert ref.name == "row" and ref.rows[0]["eval/mi"] == "0.5" and ref.final is None
  (tmp_path / "eval.json").write_text(json.dumps(_arm("diayn", [1.0, 1.2])))
  ref = ablations.read_reference("row", str(tmp_path / "metrics.csv"), ("eval/mi",))
  assert len(ref.rows) == 1 and ref.final["per_seed"]["eval/mi"] == [1.0, 1.2]
  with pytest.raises(ValueError, match=r"logs none of \['eval/energy_distance'\].*--eval-metrics"):
    ablations.read_reference("row", str(tmp_path), ("eval/energy_distance",))
  with pytest.raises(ValueError, match="not a run directory with metrics.csv"):
    ablations.read_reference("row", str(tmp_path / "missing"), ("eval/mi",))
  # a paper row committed under a prefix (benchmarks/paper/brax_humanoid/airl_metrics.csv) takes
  # its own eval.json, not the directory's
  _write_metrics(tmp_path / "airl_metrics.csv", {(0, 10): 0.7})
  (tmp_path / "airl_eval.json").write_text(json.dumps(_arm("airl", [2.0, 2.2])))
  ref = ablations.read_reference("row", str(tmp_path / "airl_metrics.csv"), ("eval/mi",))
  assert ref.rows[0]["eval/mi"] == "0.7" and ref.final["per_seed"]["eval/mi"] == [2.0, 2.2]


def test_a_reference_trained_without_eval_metrics_is_taken_by_its_eval_json_alone(tmp_path,
                                                                                  monkeypatch):
  # a row trained before --eval-metrics (the Humanoid DIAYN row): its metrics.csv logs no eval/mi
  _write_metrics(tmp_path / "diayn_metrics.csv", {(0, 9000): 900.0, (1, 9000): 950.0},
                 key="eval/episode_reward")
  (tmp_path / "diayn_eval.json").write_text(json.dumps(_arm("diayn", [0.2, 0.3, 0.4])))
  ref = ablations.read_reference("row", str(tmp_path / "diayn_metrics.csv"), ("eval/mi",))
  assert ref.final["per_seed"]["eval/mi"] == [0.2, 0.3, 0.4]
  assert not ablations.logs_curves(ref, ("eval/mi",))
  # its eval.json scores none of the study's metrics: nothing to compare, refused
  with pytest.raises(ValueError, match=r"logs none of \['eval/energy_distance'\] during "
                     r"training .*no eval.json beside it that scores one of them"):
    ablations.read_reference("row", str(tmp_path / "diayn_metrics.csv"),
                             ("eval/energy_distance",))
  # an eval.json whose only score is an LGR on blx's old goals (no lgr_goals recorded) is taken too
  (tmp_path / "old").mkdir()
  _write_metrics(tmp_path / "old" / "metrics.csv", {(0, 9000): 900.0}, key="eval/episode_reward")
  (tmp_path / "old" / "eval.json").write_text(json.dumps({"per_seed": {"eval/lgr": [2.0, 2.4]}}))
  old = ablations.read_reference("old", str(tmp_path / "old"), ("eval/lgr",))
  assert old.final["per_seed"][ablations.other_goals("eval/lgr")] == [2.0, 2.4]
  # the report draws it as its final evaluation, a point, and tests the arms' finals against it,
  # not their curves
  study = ablations.STUDIES["step_diayn"]
  spec = ablations.spec(study, "halfcheetah", 2, steps=2000, config={"num_evals": 2})
  name = sweep.expand(spec)[0][0]
  (tmp_path / "study" / name).mkdir(parents=True)
  _write_metrics(tmp_path / "study" / name / "metrics.csv", {(0, 2000): 1.0, (1, 2000): 1.2})
  (tmp_path / "study" / name / "eval.json").write_text(json.dumps(_arm("diayn", [1.0, 1.2])))
  import matplotlib.axes
  points, errorbar = [], matplotlib.axes.Axes.errorbar
  def spy(self, x, y, *a, **k):  # the labelled points (the arm's one evaluation during training
    if k.get("label"):           # is drawn with its spread too, unlabelled)
      points.append((k["label"], list(x), list(y), list(k["yerr"])))
    return errorbar(self, x, y, *a, **k)
  monkeypatch.setattr(matplotlib.axes.Axes, "errorbar", spy)
  table = ablations.report("step_diayn", study, str(tmp_path / "study"), spec, [ref])
  # at its 9,000 steps, MI only; beside it the arm's final evaluation, at the arm's last steps
  # (2,000) moved right by 1.5 % of the arms' span
  assert points == [("blx's step: 16 x 3.125 ms: final evaluation", [pytest.approx(0.00203)],
                     [pytest.approx(1.1)], [pytest.approx(0.1)]),
                    ("row: final evaluation", [0.009], [pytest.approx(0.3)],
                     [pytest.approx((0.02 / 3) ** 0.5)])]
  assert "against row at the same env steps" not in table
  assert "row logged none of the metrics during training" in table
  from scipy import stats
  want = stats.ttest_ind([1.0, 1.2], [0.2, 0.3, 0.4], equal_var=False)
  tail = table.split("The final evaluations")[1]
  assert "first row's (the reference's at 0.01 M env steps, the arms' at 0.00 M)" in tail
  assert (f"| blx's step: 16 x 3.125 ms | eval/mi | 1.100 ± 0.100 (2) | {want.statistic:+.2f} "
          f"| {want.pvalue:.3f} |") in tail
  # timed, it still has no curve to time: it does not join the wall-time table, which a lone arm
  # does not get
  timed_arm = [{"seed": s, "env_steps": 2000, "time": 20, "eval/mi": 1.0 + 0.2 * s}
               for s in (0, 1)]
  with open(tmp_path / "study" / name / "metrics.csv", "w", newline="") as f:
    w = csv.DictWriter(f, ["seed", "env_steps", "time", "eval/mi"])
    w.writeheader()
    w.writerows(timed_arm)
  timed_ref = dataclasses.replace(ref, rows=[dict(r, time=90) for r in ref.rows])
  table = ablations.report("step_diayn", study, str(tmp_path / "study"), spec, [timed_ref])
  assert "first arm's last evaluation" not in table and "a reference ran" not in table
  assert "The final evaluations" in table


def test_report_draws_the_reference_and_compares_the_arms_with_it(tmp_path, monkeypatch):
  study = ablations.STUDIES["step_diayn"]
  spec = ablations.spec(study, "halfcheetah", 2, steps=2000, config={"num_evals": 2})
  assert all(s.ppo == {"num_evals": 2, "num_timesteps": 2000} for _, s in sweep.expand(spec))
  name = sweep.expand(spec)[0][0]
  (tmp_path / name).mkdir()
  (tmp_path / name / "eval.json").write_text(json.dumps(_arm("diayn", [1.0, 1.2])))
  _write_metrics(tmp_path / name / "metrics.csv",
                 {(0, 1000): 0.5, (1, 1000): 0.7, (0, 2000): 1.0, (1, 2000): 1.2})
  reference = [{"seed": s, "env_steps": step, "eval/mi": 0.1 * step / 1000 + 0.1 * s}
               for s in (0, 1) for step in (1000, 2000, 9000)]
  table = ablations.report("step_diayn", study, str(tmp_path), spec,
                           [ablations.Reference("the row", reference)])
  assert "against the row at the same env steps" in table
  assert ("| blx's step: 16 x 3.125 ms | eval/mi | 0.00 M | 1.100 ± 0.100 (2) "
          "| 0.250 ± 0.050 (2)") in table
  assert "final evaluations" not in table  # a reference without its eval.json
  assert os.path.getsize(tmp_path / "curves.png") > 10_000
  assert "trained (whole" not in (tmp_path / "ablation.md").read_text()  # the 2,000 asked
  # With the reference's eval.json, each arm's final evaluation is tested against the reference's,
  # whose budget (9,000 steps) the heading names where it is not the arms' (2,000).
  final = _arm("diayn", [0.2, 0.3, 0.4])
  import matplotlib.axes
  drawn, errorbar = [], matplotlib.axes.Axes.errorbar
  monkeypatch.setattr(matplotlib.axes.Axes, "errorbar",
                      lambda self, *a, **k: drawn.append(k.get("label")) or errorbar(self, *a, **k))
  table = ablations.report("step_diayn", study, str(tmp_path), spec,
                           [ablations.Reference("the row", reference, final)])
  assert "first the row's (the reference's at 0.01 M env steps, the arms' at 0.00 M):" in table
  assert not drawn  # a reference with curves is compared by curves: no final drawn as a point
  same = ablations.report("step_diayn", study, str(tmp_path), spec, [ablations.Reference(
      "the row", [r for r in reference if r["env_steps"] <= 2000], final)])
  assert "first the row's:" in same and "reference's at" not in same
  from scipy import stats
  want = stats.ttest_ind([1.0, 1.2], [0.2, 0.3, 0.4], equal_var=False)
  tail = table.split("The final evaluations")[1]
  assert "| the row | eval/mi | 0.300 ± 0.082 (3) |  |  |" in tail
  assert (f"| blx's step: 16 x 3.125 ms | eval/mi | 1.100 ± 0.100 (2) | {want.statistic:+.2f} "
          f"| {want.pvalue:.3f} |") in tail
  # an arm that trained past the budget asked (whole PPO iterations): the header says how far
  _write_metrics(tmp_path / name / "metrics.csv", {(0, 2500): 1.0, (1, 2500): 1.2})
  ablations.report("step_diayn", study, str(tmp_path), spec)
  assert "; 0.00 M trained (whole PPO" in (tmp_path / "ablation.md").read_text()


def test_report_draws_and_tests_against_every_reference(tmp_path, monkeypatch):
  import matplotlib.axes
  drawn, plot, legend = [], matplotlib.axes.Axes.plot, matplotlib.axes.Axes.legend
  monkeypatch.setattr(matplotlib.axes.Axes, "plot",
                      lambda self, *a, **k: drawn.append(k.get("label")) or plot(self, *a, **k))
  listed = []
  monkeypatch.setattr(matplotlib.axes.Axes, "legend",
                      lambda self, *a, **k: listed.append(list(a[1])) or legend(self, *a, **k))
  study = ablations.STUDIES["step_diayn"]
  spec = ablations.spec(study, "halfcheetah", 2, steps=2000, config={"num_evals": 2})
  name = sweep.expand(spec)[0][0]
  (tmp_path / name).mkdir()
  _write_metrics(tmp_path / name / "metrics.csv", {(0, 2000): 1.0, (1, 2000): 1.2})
  (tmp_path / name / "eval.json").write_text(json.dumps(_arm("diayn", [1.0, 1.2])))
  low = [{"seed": s, "env_steps": 2000, "eval/mi": 0.2 + 0.1 * s} for s in (0, 1)]
  high = [{"seed": s, "env_steps": 2000, "eval/mi": 2.0 + 0.2 * s} for s in (0, 1)]
  table = ablations.report("step_diayn", study, str(tmp_path), spec,
                           [ablations.Reference("low", low),
                            ablations.Reference("high", high, _arm("diayn", [2.0, 2.2]))])
  # each reference's own comparison, with its own values; only "high" has a final evaluation
  assert "| 1.100 ± 0.100 (2) | 0.250 ± 0.050 (2)" in table.split("against low")[1]
  assert "| 1.100 ± 0.100 (2) | 2.100 ± 0.100 (2)" in table.split("against high")[1]
  assert table.count("The final evaluations") == 1
  assert "first high's" in table
  assert {"low", "high"} <= set(drawn)  # both drawn beside the arm
  # one legend, beside the last panel (LGR, which none of them logged), naming all three
  assert listed == [["blx's step: 16 x 3.125 ms", "low", "high"]]


def test_a_timed_reference_joins_the_wall_time_table_against_the_first_arms_target(tmp_path):
  study = ablations.STUDIES["step_diayn"]
  spec = ablations.spec(study, "halfcheetah", 2, steps=2000, config={"num_evals": 2})
  name = sweep.expand(spec)[0][0]
  (tmp_path / name).mkdir()
  with open(tmp_path / name / "metrics.csv", "w", newline="") as f:
    w = csv.DictWriter(f, ["seed", "env_steps", "time", "eval/mi"])
    w.writeheader()
    for seed in (0, 1):
      w.writerows([{"seed": seed, "env_steps": 1000, "time": 50, "eval/mi": 0.5},
                   {"seed": seed, "env_steps": 2000, "time": 90, "eval/mi": 1.0}])
  # the reference reaches the arm's last MI (1.0) only at its third evaluation, after 30 s
  timed = [{"seed": s, "env_steps": step, "time": t, "eval/mi": v} for s in (0, 1)
           for step, t, v in ((500, 10, 0.2), (1500, 20, 0.8), (2500, 30, 1.1))]
  untimed = [{k: v for k, v in r.items() if k != "time"} for r in timed]
  table = ablations.report("step_diayn", study, str(tmp_path), spec,
                           [ablations.Reference("fast", timed),
                            ablations.Reference("no clock", untimed)])
  wall = table.split("Wall time")[1]
  assert "a reference ran in a process of its own" in wall
  assert "| fast (reference) | eval/mi | 1.000 | 0.00 M | 30 s |" in wall
  assert "no clock" not in wall.split("\n\nEach arm")[0]  # without a clock it is left out


def test_the_wall_time_table_names_the_devices_each_run_trained_on_once_any_recorded(tmp_path):
  from blx.experiments import runs

  def segment(device, count=1):
    return runs.Segment("2026-11-25T00:00:00Z", 0.0, 1.0, device, "gpu", count, {})

  assert ablations.ran_on([]) == "not recorded"
  assert ablations.ran_on([segment("H200"), segment("H200"), segment("H100")]) == "H200, then H100"
  assert ablations.ran_on([segment("H100", 2)]) == "H100 x 2"
  # a process that trained nothing (it failed before its first chunk ended) is left out
  failed = runs.Segment("2026-11-28T20:17:10Z", 1.0, 1.0, "H200", "gpu", 2, {})
  assert ablations.ran_on([segment("H200"), failed, segment("H200")]) == "H200"
  # a run begun before blx recorded devices, resumed after: the first 37.4 M steps are unknown
  resumed = runs.Segment("2026-11-26T00:41:20Z", 37.4e6, 46.7e6, "H200", "gpu", 1, {})
  assert ablations.ran_on([resumed]) == "not recorded to 37.4 M steps, then H200"
  later = runs.Segment("2026-11-26T00:50:00Z", 50e6, 62.3e6, "H200", "gpu", 1, {})
  assert ablations.ran_on([resumed, later]) == (
      "not recorded to 37.4 M steps, then H200, then not recorded from 46.7 M to 50.0 M steps, "
      "then H200")
  study = ablations.STUDIES["step_diayn"]
  spec = ablations.spec(study, "halfcheetah", 2, steps=2000, config={"num_evals": 2})
  names = [name for name, _ in sweep.expand(spec)]
  for name in names:
    (tmp_path / name).mkdir()
    with open(tmp_path / name / "metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "time", "eval/mi"])
      w.writeheader()
      w.writerows([{"seed": s, "env_steps": 2000, "time": 90, "eval/mi": 1.0} for s in (0, 1)])
  reference = [{"seed": s, "env_steps": 2000, "time": 30, "eval/mi": 1.0} for s in (0, 1)]
  table = ablations.report("step_diayn", study, str(tmp_path), spec,
                           [ablations.Reference("old row", reference)])
  assert "ran on" not in table  # no run recorded its device: no column of "not recorded"
  # the first arm was trained by a blx that writes provenance.json, on a GPU and resumed on another
  runs._write_provenance(str(tmp_path / names[0]), [segment("H200"), segment("H100")])
  table = ablations.report("step_diayn", study, str(tmp_path), spec,
                           [ablations.Reference("old row", reference)])
  wall = table.split("Wall time")[1].split("\n\nEach arm")[0]
  assert "| wall time | ran on |" in wall
  first, second, old = [r for r in wall.splitlines() if r.startswith("| ") and "eval/mi" in r]
  assert first.endswith("| 90 s | H200, then H100 |")
  assert second.endswith("| 90 s | not recorded |") and old.endswith("| 30 s | not recorded |")
  # an arm whose curves were logged with the final protocol (10 episodes) says so in its label
  runs._write_provenance(str(tmp_path / names[1]), [
      dataclasses.replace(segment("H200"), eval_protocol="final")])
  table = ablations.report("step_diayn", study, str(tmp_path), spec)
  labelled = [r for r in table.splitlines() if "(curves: the final protocol)" in r]
  second_arm = study.label(*sweep.expand(spec)[1])
  assert labelled and all(r.startswith(f"| {second_arm} (curves") for r in labelled)


def test_an_arm_trained_for_another_budget_than_the_reports_is_labelled_with_its_own(tmp_path):
  study = ablations.STUDIES["push_scale"]
  spec = ablations.spec(study, "ant", 2, steps=3000, config={"num_evals": 2})
  (first, first_spec), (second, second_spec) = sweep.expand(spec)[:2]
  for name, run_spec, steps in ((first, first_spec, 3000), (second, second_spec, 1000)):
    trained = dataclasses.replace(run_spec, ppo={**run_spec.ppo, "num_timesteps": steps})
    _trained(tmp_path / name, trained)
    _write_metrics(tmp_path / name / "metrics.csv", {(0, 1000): 1.0, (1, 1000): 2.0},
                   key="eval/episode_score")
  table = ablations.report("push_scale", study, str(tmp_path), spec)
  rows = [r for r in table.splitlines() if "eval/episode_score" in r]
  assert rows[0].startswith("| scale 1 (the env's) (unfinished) |")  # the report's own budget
  assert rows[1].startswith("| scale 0.2 (a 0.001 M budget) (unfinished) |")


def _trained(path, run_spec):
  """``run_spec``'s config.json in ``path``, and a provenance.json whose segment records the
  settings it trained with under blx's defaults now, as ``train_run`` writes them."""
  import json
  import types
  from blx.experiments import runs
  from blx.training import config as ppo_config
  runs.write_config(str(path), run_spec, types.SimpleNamespace(desc={}))
  ppo = dataclasses.asdict(ppo_config.ppo_defaults(run_spec.env, **run_spec.ppo))
  (path / "provenance.json").write_text(json.dumps({"segments": [
      {"started": "2026-11-30T00:00:00Z", "from_env_steps": 0.0, "to_env_steps": 1000.0,
       "device": "cpu", "platform": "cpu", "device_count": 1, "versions": {}, "ppo": ppo}]}))


def test_a_report_names_the_ppo_settings_its_arms_trained_with_over_the_row(tmp_path):
  study = ablations.STUDIES["legs_original"]
  # the arms trained with a larger entropy cost (--config); the report is asked with it, so the
  # title and ablation.md name it, and no arm's label repeats it
  spec = ablations.spec(study, "ant", 2, steps=3000, config={"entropy_cost": 0.1})
  (first, first_spec), (second, second_spec) = sweep.expand(spec)[:2]
  for name, run_spec in ((first, first_spec), (second, second_spec)):
    _trained(tmp_path / name, run_spec)
    _write_metrics(tmp_path / name / "metrics.csv", {(0, 1000): 1.0, (1, 1000): 2.0},
                   key="eval/episode_score")
  table = ablations.report("legs_original", study, str(tmp_path), spec)
  written = (tmp_path / "ablation.md").read_text()
  assert "Every arm's PPO over the row's: entropy_cost=0.1." in written
  assert "trained with" not in table
  # the same arms reported without --config: each label says what its arm trained with
  plain = ablations.spec(study, "ant", 2, steps=3000)
  table = ablations.report("legs_original", study, str(tmp_path), plain)
  rows = [r for r in table.splitlines() if "eval/episode_score" in r]
  assert rows and all("(trained with entropy_cost=0.1)" in r for r in rows)
  assert "over the row's" not in (tmp_path / "ablation.md").read_text()
  # and an arm trained with the row's setting, reported with --config, says that
  _trained(tmp_path / first, sweep.expand(plain)[0][1])
  table = ablations.report("legs_original", study, str(tmp_path), spec)
  rows = [r for r in table.splitlines() if "eval/episode_score" in r]
  assert "(trained with the row's entropy_cost)" in rows[0]
  assert "trained with" not in rows[1]


def test_a_report_names_a_setting_an_arm_took_from_a_default_that_moved_since(tmp_path,
                                                                              monkeypatch):
  import json
  import types
  from blx.experiments import runs
  from blx.training import config as ppo_config
  study = ablations.STUDIES["legs_original"]
  spec = ablations.spec(study, "ant", 2, steps=3000)
  (older, older_spec), (recorded, recorded_spec) = sweep.expand(spec)[:2]
  for name, run_spec in ((older, older_spec), (recorded, recorded_spec)):
    runs.write_config(str(tmp_path / name), run_spec, types.SimpleNamespace(desc={}))
    _write_metrics(tmp_path / name / "metrics.csv", {(0, 1000): 1.0, (1, 1000): 2.0},
                   key="eval/episode_score")
  # Neither config.json sets eval_actions. The older arm records no settings (before session
  # 60: the mean action); the other's provenance records every setting it trained with.
  segment = {"started": "2026-11-30T00:00:00Z", "from_env_steps": 0.0, "to_env_steps": 1000.0,
             "device": "cpu", "platform": "cpu", "device_count": 1, "versions": {}}
  sampled = dataclasses.asdict(ppo_config.ppo_defaults("pro_ant_run", eval_actions="sampled",
                                                       num_timesteps=3000))
  (tmp_path / recorded / "provenance.json").write_text(json.dumps(
      {"segments": [{**segment, "ppo": sampled}]}))

  def labels():
    table = ablations.report("legs_original", study, str(tmp_path), spec)
    return [r.split(" | ")[0] for r in table.splitlines() if "eval/episode_score" in r][:2]

  # Under blx's defaults before session 61 (the mean action) the recorded arm is named, the
  # older not.
  row = ppo_config.ppo_defaults
  with monkeypatch.context() as before:
    before.setattr(ppo_config, "ppo_defaults",
                   lambda env=None, **kw: row(env, **{"eval_actions": "mean", **kw}))
    older_label, recorded_label = labels()
  assert "trained with" not in older_label
  assert "(trained with eval_actions='sampled')" in recorded_label
  # blx's default samples now: the older arm is named for its mean action, the other not.
  older_label, recorded_label = labels()
  assert "(trained with eval_actions='mean')" in older_label
  assert "trained with" not in recorded_label
  # A study that does not report the return episodes (MI, H(s)) leaves how they acted out.
  path, older_spec = str(tmp_path / older), dict(sweep.expand(spec))[older]
  assert ablations._other_settings(path, older_spec) == " (trained with eval_actions='mean')"
  assert ablations._other_settings(path, older_spec, returns=False) == ""


def test_a_task_study_compares_the_training_reward_where_one_episodes_score_dips(tmp_path):
  # A task study's evaluation is one episode per seed (the mean action from a reset without
  # noise): one seed's dip can hide a difference the training reward, over every env, still shows
  # (RESULTS, session 57: four against three legs at 75 M, score p 0.57, training reward p < 0.001).
  import types
  from blx.experiments import runs
  study = ablations.STUDIES["legs_original"]
  spec = ablations.spec(study, "ant", 4, steps=3000, config={"num_evals": 1})
  (four, four_spec), (two, two_spec) = sweep.expand(spec)[:2]
  arms = {four: ([-250.0, -260.0, -240.0, -2200.0], [4.6, 4.65, 4.62, 4.55]),
          two: ([-700.0, -650.0, -720.0, -690.0], [4.1, 4.2, 4.15, 4.18])}
  for name, run_spec in ((four, four_spec), (two, two_spec)):
    runs.write_config(str(tmp_path / name), run_spec, types.SimpleNamespace(desc={}))
    scores, rewards = arms[name]
    with open(tmp_path / name / "metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "eval/episode_score", "eval/episode_length",
                             "train/env_reward"])
      w.writeheader()
      for seed, (score, reward) in enumerate(zip(scores, rewards)):
        w.writerow({"seed": seed, "env_steps": 3000, "eval/episode_score": score,
                    "eval/episode_length": 1000.0, "train/env_reward": reward})
  table = ablations.report("legs_original", study, str(tmp_path), spec)
  p = {row.split(" | ")[1]: row.rstrip(" |").rsplit(" | ", 1)[-1]
       for row in table.split("Welch t vs first")[1].split("\n\n")[0].splitlines()
       if row.startswith(f"| {study.label(two, two_spec)}")}
  assert float(p["eval/episode_score"]) > 0.3      # the dip hides the difference in the score
  assert p["train/env_reward"] == "< 0.001"        # the training reward shows it
  # an arm finished (eval.json, which has no training reward) compares its final evaluations by
  # the evaluation's own metrics only
  for name in (four, two):
    scores, _ = arms[name]
    with open(tmp_path / name / "eval.json", "w") as f:
      json.dump({"objective": "task", "per_seed": {"eval/episode_score": scores,
                                                   "eval/episode_length": [1000.0] * 4}}, f)
  table = ablations.report("legs_original", study, str(tmp_path), spec)
  finals = table.split("\n\n")[0]
  assert "eval/episode_score" in finals and "train/env_reward" not in finals


def test_references_named_twice_or_too_many_are_refused_before_anything_trains(
    monkeypatch, capsys, tmp_path):
  _write_metrics(tmp_path / "metrics.csv", {(0, 10): 0.5})
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(a))
  for refs, message in ((["a", "a"], "--reference 'a': named twice"),
                        (["a", "b", "c", "d"], "4 given; at most 3")):
    argv = [x for name in refs for x in ("--reference", f"{name}={tmp_path}")]
    monkeypatch.setattr("sys.argv", ["ablations.py", "sn_diayn", "--out", str(tmp_path), *argv])
    with pytest.raises(SystemExit):
      ablations.main()
    assert message in capsys.readouterr().err
  assert not trained


@pytest.mark.parametrize("argv,message", [
    (["--reference", "no-equals-sign"], "give NAME=PATH"),
    (["--reference", "row=/nowhere"], "not a run directory"),
    (["--config", "[1]"], "a JSON object of PPO settings"),
    (["--config", '{"num_evalz": 3}'], r"unknown key\(s\) \['num_evalz'\]"),
])
def test_bad_reference_or_config_is_refused_before_anything_trains(argv, message, monkeypatch,
                                                                     capsys, tmp_path):
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(a))
  monkeypatch.setattr("sys.argv", ["ablations.py", "sn_diayn", "--out", str(tmp_path), *argv])
  with pytest.raises(SystemExit):
    ablations.main()
  assert re.search(message, capsys.readouterr().err)
  assert not trained


def test_the_eval_protocol_reaches_every_arm(monkeypatch, tmp_path):
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(k))
  monkeypatch.setattr(ablations, "report", lambda *a: "")
  # no flag: None, each arm's own protocol where it resumes, else quick (runs.check_eval_protocol)
  for given, protocol in (([], None), (["--eval-protocol", "final"], "final")):
    monkeypatch.setattr("sys.argv", ["ablations.py", "sn_diayn", "--out", str(tmp_path), *given])
    ablations.main()
    assert (trained[-1]["eval_metrics"], trained[-1]["eval_protocol"]) == (True, protocol)


def test_a_reference_named_as_an_arm_is_refused_before_anything_trains(monkeypatch, capsys,
                                                                        tmp_path):
  _write_metrics(tmp_path / "metrics.csv", {(0, 10): 0.5})
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(a))
  monkeypatch.setattr("sys.argv", ["ablations.py", "step_diayn", "--env", "halfcheetah", "--out",
                                   str(tmp_path), "--reference", f"8 x 6.25 ms={tmp_path}"])
  with pytest.raises(SystemExit):
    ablations.main()
  assert "--reference '8 x 6.25 ms': an arm's name" in capsys.readouterr().err
  assert not trained


def test_objective_and_arm_pick_the_points_this_call_trains(monkeypatch, tmp_path):
  calls = []
  monkeypatch.setattr(sweep, "run_sweep", lambda spec, out, **k: calls.append((spec, k)))
  monkeypatch.setattr(ablations, "report", lambda *a, **k: "")
  monkeypatch.setattr("sys.argv", ["ablations.py", "gp", "--out", str(tmp_path), "--objective",
                                   "airl", "--arm", "0.0", "--arm", "10.0"])
  ablations.main()
  (spec, kwargs), = calls
  picked = [name for name, run_spec in sweep.expand(spec) if kwargs["select"](name, run_spec)]
  study = ablations.STUDIES["gp"]
  assert sorted((r.objective, study.value(r)) for n, r in sweep.expand(spec) if n in picked) == [
      ("airl", 0.0), ("airl", 10.0)]
  assert len(list(sweep.expand(spec))) == 6  # the other four points stay untrained


def test_an_objective_outside_the_study_is_refused_before_anything_trains(monkeypatch, capsys,
                                                                           tmp_path):
  trained = []
  monkeypatch.setattr(sweep, "run_sweep", lambda *a, **k: trained.append(a))
  monkeypatch.setattr("sys.argv", ["ablations.py", "gp", "--out", str(tmp_path), "--objective",
                                   "gail2"])
  with pytest.raises(SystemExit):
    ablations.main()
  assert "--objective ['gail2']: gp's objectives are ['airl', 'gail']" in capsys.readouterr().err
  assert not trained


def test_an_unfinished_arm_is_drawn_and_compared_at_the_last_steps_every_arm_reached(tmp_path):
  study = ablations.STUDIES["gp"]
  spec = ablations.spec(study, "ant", 2)
  points = dict((study.value(r), name) for name, r in sweep.expand(spec) if r.objective == "airl")
  done, open_ = tmp_path / points[0.0], tmp_path / points[10.0]
  done.mkdir(), open_.mkdir()
  key, m = "eval/energy_distance", 1e6
  (done / "eval.json").write_text(json.dumps(
      {"objective": "airl", "per_seed": {key: [1.9, 2.1]}}))
  # The finished arm ran to 30 M; the unfinished one stopped after 20 M, so they meet at 20 M.
  _write_metrics(done / "metrics.csv", {(0, 10 * m): 2.5, (1, 10 * m): 2.7, (0, 20 * m): 1.8,
                                        (1, 20 * m): 2.0, (0, 30 * m): 9.0, (1, 30 * m): 9.0}, key)
  _write_metrics(open_ / "metrics.csv", {(0, 10 * m): 2.8, (1, 10 * m): 2.8, (0, 20 * m): 2.7,
                                         (1, 20 * m): 2.9}, key)
  table = ablations.report("gp", study, str(tmp_path), spec)
  finals, during = table.split("An arm is unfinished")
  assert "(unfinished)" not in finals  # no eval.json: not among the final evaluations
  from scipy import stats
  want = stats.ttest_ind([2.7, 2.9], [1.8, 2.0], equal_var=False)
  during = during.split("\n\nWall time")[0]  # the tables of wall time follow
  rows = [r for r in during.splitlines() if r.startswith("| airl")]
  assert [[c.strip() for c in r.split("|")[3:7]] for r in rows] == [
      ["20.00 M", "1.900 ± 0.100 (2)", "", ""],
      ["20.00 M", "2.800 ± 0.100 (2)", f"{want.statistic:+.2f}", f"{want.pvalue:.3f}"]]
  assert "(unfinished)" in rows[1] and "(unfinished)" not in rows[0]
  assert os.path.getsize(tmp_path / "curves.png") > 10_000
  # Stopped before any arm's final evaluation: still drawn and compared during training.
  (done / "eval.json").unlink()
  table = ablations.report("gp", study, str(tmp_path), spec)
  finals, during = table.split("An arm is unfinished")
  assert finals.startswith("No arm has its final evaluation (eval.json) yet.")
  during = during.split("\n\nWall time")[0]
  assert [r for r in during.splitlines() if r.startswith("| airl")] == [
      rows[0].replace("row)", "row) (unfinished)"), rows[1]]
  (done / "metrics.csv").unlink(), (open_ / "metrics.csv").unlink()
  with pytest.raises(SystemExit, match="no arm of gp has run yet"):
    ablations.report("gp", study, str(tmp_path), spec)


def test_an_interrupted_study_says_how_to_continue_and_exits_130_without_a_report(
    monkeypatch, capsys, tmp_path):
  def interrupted(*args, **kwargs):  # a Ctrl-C (or a timeout's SIGINT) while an arm trains
    raise KeyboardInterrupt

  reported = []
  monkeypatch.setattr(sweep, "run_sweep", interrupted)
  monkeypatch.setattr(ablations, "report", lambda *a, **k: reported.append(a) or "")
  monkeypatch.setattr("sys.argv", ["ablations.py", "gp", "--out", str(tmp_path)])
  with pytest.raises(SystemExit) as stop:
    ablations.main()
  assert stop.value.code == 130
  assert f"[ablations] {sweep.INTERRUPTED}" in capsys.readouterr().err
  assert not reported


def test_runs_from_before_mode_balance_get_it_from_their_modes_shares(tmp_path):
  study = ablations.STUDIES["gp"]
  assert "eval/mode_balance" in study.metrics
  spec = ablations.spec(study, "ant", 2)
  points = dict((study.value(r), name) for name, r in sweep.expand(spec) if r.objective == "airl")
  shares = {0.0: ([1.0, 0.9], [0.0, 0.1]), 1.0: ([0.5, 0.6], [0.5, 0.4])}  # seeds 0 and 1
  for value, (zero, one) in shares.items():
    d = tmp_path / points[value]
    d.mkdir()
    (d / "eval.json").write_text(json.dumps({"objective": "airl", "per_seed": {
        "eval/energy_distance": [2.0, 2.1], "eval/mode_share/0": zero, "eval/mode_share/1": one}}))
    with open(d / "metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "time", "eval/energy_distance",
                             "eval/mode_share/0", "eval/mode_share/1"])
      w.writeheader()
      w.writerows([{"seed": s, "env_steps": 1e6, "time": 10, "eval/energy_distance": 2.0,
                    "eval/mode_share/0": zero[s], "eval/mode_share/1": one[s]} for s in (0, 1)])
  table = ablations.report("gp", study, str(tmp_path), spec)
  finals = table.split("Wall time")[0]
  # 2 x the least share per seed: committed (0, 0.2) and split (1.0, 0.8)
  assert "| airl, no penalty (the paper's row) | eval/mode_balance | 0.100 ± 0.100 (2) |" in finals
  assert "| airl, penalty weight 1 | eval/mode_balance | 0.900 ± 0.100 (2) |" in finals
  # a run that logged the balance itself keeps its own value
  logged = [{"eval/mode_share/0": "0.5", "eval/mode_share/1": "0.5", "eval/mode_balance": "0.7"}]
  assert ablations.with_mode_balance(logged)[0]["eval/mode_balance"] == "0.7"
  assert ablations.with_mode_balance([{"eval/mi": "1.0"}]) == [{"eval/mi": "1.0"}]  # no modes


def test_a_reference_of_one_objective_faces_only_the_arms_of_that_objective(tmp_path):
  # The gp study on Humanoid: the AIRL and GAIL arms at weight 1, each against its own objective's
  # paper row (weight 0), committed under a prefix with its config.json naming the objective.
  study = ablations.STUDIES["gp"]
  spec = ablations.spec(study, "humanoid", 2, steps=2000, config={"num_evals": 2})
  key = "eval/energy_distance"
  names = {s.objective: n for n, s in sweep.expand(spec) if study.value(s) == 1.0}
  for objective, value in (("airl", 2.0), ("gail", 1.0)):
    (tmp_path / names[objective]).mkdir()
    with open(tmp_path / names[objective] / "metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "time", key])
      w.writeheader()
      w.writerows({"seed": s, "env_steps": 2000, "time": 90, key: value + 0.1 * s} for s in (0, 1))
    (tmp_path / names[objective] / "eval.json").write_text(json.dumps(
        {"objective": objective, "per_seed": {key: [value, value + 0.1]}}))
  rows = tmp_path / "rows"
  rows.mkdir()
  for objective, value in (("airl", 3.0), ("gail", 5.0)):
    with open(rows / f"{objective}_metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "time", key])
      w.writeheader()
      w.writerows({"seed": s, "env_steps": step, "time": step / 10,
                   key: value - step / 1000 + 0.05 * s}
                  for s in (0, 1) for step in (1000, 2000, 3000))
    (rows / f"{objective}_config.json").write_text(json.dumps({"objective": objective}))
    (rows / f"{objective}_eval.json").write_text(json.dumps(
        {"objective": objective, "per_seed": {key: [value, value + 0.2]}}))
  refs = [ablations.read_reference(f"{o.upper()} row", str(rows / f"{o}_metrics.csv"), (key,))
          for o in ("airl", "gail")]
  assert [r.objective for r in refs] == ["airl", "gail"]
  anyone = ablations.Reference("no objective", refs[0].rows)
  table = ablations.report("gp", study, str(tmp_path), spec, refs + [anyone])
  airl, gail = "airl, penalty weight 1", "gail, penalty weight 1"
  assert airl in table and gail in table
  against_airl = table.split("against AIRL row at the same env steps")[1].split("\n\n")[1]
  assert "Each airl arm's last evaluation" in table
  assert airl in against_airl and gail not in against_airl
  against_gail = table.split("against GAIL row at the same env steps")[1].split("\n\n")[1]
  assert gail in against_gail and airl not in against_gail
  assert f"| {gail} | {key} | 0.00 M | 1.050 ± 0.050 (2) | 3.025 ± 0.025 (2) |" in against_gail
  # a reference that names no objective faces every arm, as before
  against_any = table.split("against no objective at the same env steps")[1].split("\n\n")[1]
  assert airl in against_any and gail in against_any
  # the final evaluations: each row with its own objective's arm only, tested against the row
  final_airl = table.split("first AIRL row's")[1].split("\n\n")[1]
  assert airl in final_airl and gail not in final_airl
  from scipy import stats
  t = stats.ttest_ind([2.0, 2.1], [3.0, 3.2], equal_var=False).statistic
  assert final_airl.splitlines()[-1].startswith(
      f"| {airl} | {key} | 2.050 ± 0.050 (2) | {t:+.2f} |")
  final_gail = table.split("first GAIL row's")[1].split("\n\n")[1]
  assert gail in final_gail and airl not in final_gail
  assert "arms of another objective" not in table
  # in the wall-time table each timed row chases its own objective's first arm's last mean: the
  # AIRL row reaches the AIRL arm's 2.05 at 1,000 steps (100 s); the GAIL row (at best 2.025)
  # never reaches the GAIL arm's 1.05
  wall = table.split("Wall time")[1].split("\n\nEach")[0]
  assert f"| AIRL row (reference) | {key} | 2.050 | 0.00 M | 100 s |" in wall
  assert f"| GAIL row (reference) | {key} | 1.050 | not reached |" in wall


def test_an_lgr_not_on_the_papers_goals_is_its_own_metric_never_tested_beside_one_that_is(
    tmp_path):
  from blx.experiments import runs

  def segment(to, goals):
    return runs.Segment("2026-11-27T00:00:00Z", 0.0, to, "H200", "gpu", 1, {}, lgr_goals=goals)

  other = ablations.other_goals("eval/lgr")
  assert other == "eval/lgr" + ablations.paper_tables.OTHER_GOALS
  assert ablations.with_other_goals(("eval/mi", "eval/lgr")) == ("eval/mi", "eval/lgr", other)
  # a run resumed by a blx that draws the paper's goals: the evaluations up to 2,000 steps were on
  # the old goals (a segment without lgr_goals), those after on the paper's; none recorded: old
  rows = [{"seed": 0, "env_steps": step, "eval/mi": 1.0, "eval/lgr": lgr}
          for step, lgr in ((1000, 2.0), (2000, 2.1), (3000, 0.9))]
  moved = ablations.with_lgr_goals(rows, [segment(2000, None), segment(3000, "braxlines")])
  assert [(r.get("eval/lgr"), r.get(other)) for r in moved] == [(None, 2.0), (None, 2.1),
                                                               (0.9, None)]
  assert all(r["eval/mi"] == 1.0 for r in moved)
  assert all(other in r for r in ablations.with_lgr_goals(rows, []))
  # a run begun before blx recorded provenance and resumed with the paper's goals at 2,000 steps:
  # the evaluations before it have no segment, so they were on the old goals
  resumed = dataclasses.replace(segment(3000, "braxlines"), from_env_steps=2000.0)
  assert [other in r for r in ablations.with_lgr_goals(rows, [resumed])] == [True, True, False]
  # the finals: an eval.json that does not record the paper's goals keeps its LGR apart
  old = {"objective": "diayn", "per_seed": {"eval/mi": [1.0, 1.1], "eval/lgr": [2.0, 2.2]}}
  new = {"objective": "diayn", "per_seed": {"eval/mi": [0.5, 0.6], "eval/lgr": [0.8, 0.9]},
         "evaluated_on": {"lgr_goals": "braxlines"}}
  assert ablations.final_with_lgr_goals(new) == new
  assert set(ablations.final_with_lgr_goals(old)["per_seed"]) == {"eval/mi", other}
  # a study whose first arm is on the old goals and its second on the paper's: MI is tested, the
  # two LGRs are tabulated apart, and neither is tested against the other
  study = ablations.STUDIES["skills"]
  spec = ablations.spec(study, "ant", 2, steps=3000)
  names = [name for name, _ in sweep.expand(spec)][:2]
  for name, final, segments in ((names[0], old, [segment(3000, None)]),
                                (names[1], new, [segment(3000, "braxlines")])):
    (tmp_path / name).mkdir()
    (tmp_path / name / "eval.json").write_text(json.dumps(final))
    with open(tmp_path / name / "metrics.csv", "w", newline="") as f:
      w = csv.DictWriter(f, ["seed", "env_steps", "eval/mi", "eval/lgr"])
      w.writeheader()
      w.writerows([{"seed": s, "env_steps": 3000, "eval/mi": 1.0 + s, "eval/lgr": 2.0 + s}
                   for s in (0, 1)])
    runs._write_provenance(str(tmp_path / name), segments)
  table = ablations.report("skills", study, str(tmp_path), spec)
  finals = table.split("\n\n")[0].splitlines()
  first, second = (study.label(*sweep.expand(spec)[i]) for i in (0, 1))
  mi = [r for r in finals if r.startswith(f"| {second} | eval/mi |")]
  assert len(mi) == 1 and mi[0].endswith("| -7.07 | 0.019 |")  # tested against the first arm
  assert [r for r in finals if "eval/lgr" in r] == [
      f"| {first} | {other} | 2.100 ± 0.100 (2) |  |  |",
      f"| {second} | eval/lgr | 0.850 ± 0.050 (2) |  |  |"]
  assert os.path.getsize(tmp_path / "curves.png") > 10_000
  # a reference committed under a prefix reads its prefix's provenance: its LGR from 2,000 steps on
  # was on the paper's goals
  _write_metrics(tmp_path / "row_metrics.csv",
                 {(s, step): 1.0 for s in (0, 1) for step in (1000, 3000)}, key="eval/lgr")
  runs._write_provenance(str(tmp_path), [segment(2000, None), segment(3000, "braxlines")])
  os.replace(tmp_path / runs.PROVENANCE, tmp_path / "row_provenance.json")
  reference = ablations.read_reference("row", str(tmp_path / "row_metrics.csv"), ("eval/lgr",))
  assert [r["env_steps"] for r in reference.rows if "eval/lgr" in r] == ["3000"] * 2
  assert len(reference.segments) == 2
  # against a reference that scored the LGR on the old goals only, an arm's LGR on the paper's
  # goals is not set beside it
  rows = ablations.against({"arm": moved}, "old row", ablations.with_lgr_goals(rows, []),
                           ("eval/lgr",))
  assert rows[2] == "| arm | eval/lgr | 0.00 M | 0.900 ± 0.000 (1) | no eval/lgr |  |  |"
