"""benchmarks/ablations.py: arms that differ from the paper's row in one setting, their curves and
their comparison."""

import csv
import inspect
import json
import os

import pytest

from blx.experiments import sweep
from blx.objectives import presets
from tests.experiments import load_benchmark

ablations = load_benchmark("ablations")


def _default(objective, option):
  return inspect.signature(presets._preset(objective)).parameters[option].default


_STUDY_ENVS = [(name, env) for name, study in sorted(ablations.STUDIES.items())
               for env in (study.envs or ("ant", "humanoid"))]


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


def test_curve_is_the_mean_and_std_over_seeds_where_every_seed_was_evaluated():
  values = {(0, 10): "1.0", (1, 10): "3.0", (0, 20): "2.0", (1, 20): "",  # seed 1 missed step 20
            (0, 30): "4.0", (1, 30): "6.0"}
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
  t, p = (float(x) for x in off.strip("| ").split(" | ")[-2:])
  assert t < -5 and p < 0.001
  assert "0.500 ± 0.071 (5)" in off


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
  assert [gp.label(n, s) for n, s in points][:2] == [
      "objective=airl, gradient_penalty_weight=0.0", "objective=airl, gradient_penalty_weight=1.0"]
  assert gp.claim_line.startswith("the paper: ")
