"""benchmarks/ablations.py: arms that differ from the paper's row in one setting, their curves and
their comparison."""

import csv
import importlib.util
import inspect
import json
import os
import pathlib
import sys

import pytest

from blx.experiments import sweep
from blx.objectives import presets

_PATH = pathlib.Path(__file__).resolve().parents[2] / "benchmarks" / "ablations.py"
_spec = importlib.util.spec_from_file_location("ablations", _PATH)
ablations = importlib.util.module_from_spec(_spec)
sys.modules["ablations"] = ablations  # dataclasses look their module up
_spec.loader.exec_module(ablations)


def _default(objective, option):
  return inspect.signature(presets._preset(objective)).parameters[option].default


@pytest.mark.parametrize("name", sorted(ablations.STUDIES))
@pytest.mark.parametrize("env", ["ant", "humanoid"])
def test_arms_differ_from_the_paper_row_in_the_studied_option_only(name, env):
  study = ablations.STUDIES[name]
  row = ablations.paper_tables.specs(10, env=env)[study.family]
  points = sweep.expand(ablations.spec(study, env, 10))
  assert len(points) == len(study.objectives) * len(study.values)
  for objective in study.objectives:
    arms = [s for _, s in points if s.objective == objective]
    assert [s.objective_options[study.option] for s in arms] == list(study.values)
    # The first arm is the paper's row: its value is the row's, or the objective's default.
    assert study.values[0] == row["options"].get(study.option, _default(objective, study.option))
    for arm in arms:
      rest = {k: v for k, v in arm.objective_options.items() if k != study.option}
      assert rest == {k: v for k, v in row["options"].items() if k != study.option}
      assert (arm.env, arm.seeds) == (env, tuple(range(10)))
      assert arm.ppo == {"num_timesteps": row["steps"]}


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
