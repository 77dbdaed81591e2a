"""The paper's ablations (#15), each one command: arms that differ in one setting from the paper's
row, trained with the row's protocol, compared by curves and by a Welch test against the first arm.

    python benchmarks/ablations.py STUDY [--env ant|humanoid|halfcheetah] [--seeds 10]
                                         [--out sweeps/ablations] [--steps N] [--arm VALUE]
    python benchmarks/ablations.py STUDY --report    # only the curves and table of what has run

Studies (``--list`` prints them):
- ``sn_diayn``: DIAYN with spectral norm (the paper's row) and without (the paper: SN helps, on Ant
  and Humanoid);
- ``sn_cdiayn``: the same for cDIAYN;
- ``gp``: AIRL and GAIL with gradient penalty weight 0 (the paper's rows), 1 and 10 (the paper: no
  significant gain; too much penalty hurts). The paper does not give its weights; these are ours;
- ``skills``: DIAYN with 2, 4, 8 (the paper's row) and 16 skills;
- ``run_reward``: DIAYN on the xy velocity with the ant's own running reward added
  (``env_reward_multiplier`` 0, the row, and 1): distinct gaits that all run.

Each arm is a point of one ``blx sweep`` (``benchmarks/paper_tables.py`` gives the row's settings),
trained with ``--eval-metrics`` so that MI, H(s) or the energy distance is logged at every
evaluation. Points already evaluated are reused, so ``--arm`` lets one process per GPU train one
arm and a last call (``--report``) draws them together. Writes ``OUT/STUDY_ENV/``: the sweep's run
directories, ``curves.png`` (each metric against env steps, mean and std over seeds per arm) and
``ablation.md`` (each arm's final metrics, mean +- std over seeds, Welch's t-test against the first
arm).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import importlib.util
import json
import math
import os

_HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("paper_tables",
                                               os.path.join(_HERE, "paper_tables.py"))
paper_tables = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(paper_tables)


@dataclasses.dataclass(frozen=True)
class Study:
  """Arms that differ from the paper's row of ``family`` in the objective option ``option``; the
  first value is the row's own."""

  family: str                  # the paper_tables family whose settings every arm shares
  objectives: tuple[str, ...]
  option: str
  values: tuple
  metrics: tuple[str, ...]     # eval.json / metrics.csv keys; compared at the last evaluation
  claim: str                   # the paper's conclusion the study tests


STUDIES = {
    "sn_diayn": Study("mimax", ("diayn",), "spectral_norm", (True, False),
                      ("eval/mi", "eval/entropy"), "spectral norm improves DIAYN's MI and H(s)"),
    "sn_cdiayn": Study("mimax", ("cdiayn",), "spectral_norm", (True, False),
                       ("eval/mi", "eval/entropy"), "spectral norm makes cDIAYN's skills distinct"),
    "gp": Study("dmin", ("airl", "gail"), "gradient_penalty_weight", (0.0, 1.0, 10.0),
                ("eval/energy_distance",), "gradient penalty does not help much; too much hurts"),
    "skills": Study("mimax", ("diayn",), "num_skills", (8, 2, 4, 16), ("eval/mi", "eval/entropy"),
                    "(no claim in the paper; MI is bounded by log K)"),
    "run_reward": Study("mimax", ("diayn",), "env_reward_multiplier", (0.0, 1.0),
                        ("eval/mi", "eval/entropy", "eval/episode_env_reward"),
                        "with the run reward, skills are gaits that all run"),
}


LABELS = {"eval/mi": "MI(s, z)", "eval/entropy": "H(s)",
          "eval/energy_distance": "energy distance (lower is better)",
          "eval/episode_env_reward": "episode env reward"}


def spec(study: Study, env: str, seeds: int, steps: int | None = None) -> dict:
  """One sweep over the study's objectives x values, on the settings of the paper's row."""
  base = paper_tables.specs(seeds, steps=steps, env=env)[study.family]
  options = dict(base["options"])
  options[study.option] = list(study.values)
  return dict(base, name=f"ablation_{study.option}_{env}", objective=list(study.objectives),
              options=options)


def curve(rows: list[dict], key: str) -> tuple[list[float], list[float], list[float]]:
  """``(env steps, mean, std)`` over seeds of ``key`` in metrics.csv rows, at every evaluation
  where every seed has a value."""
  by_step: dict[float, list[float]] = {}
  for row in rows:
    value = row.get(key, "")
    if value not in ("", None) and math.isfinite(float(value)):
      by_step.setdefault(float(row["env_steps"]), []).append(float(value))
  seeds = max((len(v) for v in by_step.values()), default=0)
  steps = sorted(s for s, v in by_step.items() if len(v) == seeds)
  mean = [sum(by_step[s]) / seeds for s in steps]
  std = [math.sqrt(sum((x - m) ** 2 for x in by_step[s]) / seeds) for s, m in zip(steps, mean)]
  return steps, mean, std


def compare(arms: dict[str, dict], metrics: tuple[str, ...]) -> list[str]:
  """Markdown rows: per arm and metric, mean +- std over seeds, and Welch's t-test against the
  first arm of the same objective. ``arms``: ``{name: eval.json}``."""
  from scipy import stats
  rows = ["| arm | metric | mean ± std (seeds) | Welch t vs first | p |",
          "| --- | --- | ---: | ---: | ---: |"]
  first: dict[str, str] = {}  # objective -> its first arm
  for name, result in arms.items():
    reference = first.setdefault(result["objective"], name)
    for key in metrics:
      values = result["per_seed"].get(key)
      if not values:
        continue
      n = len(values)
      mean, std = paper_tables.mean_std(values)
      ref = arms[reference]["per_seed"].get(key)
      t, p = "", ""
      if name != reference and ref and n > 1 and len(ref) > 1:
        test = stats.ttest_ind(values, ref, equal_var=False)
        t, p = f"{test.statistic:+.2f}", f"{test.pvalue:.3f}"
      rows.append(f"| {name} | {key} | {mean:.3f} ± {std:.3f} ({n}) | {t} | {p} |")
  return rows


def report(study_name: str, study: Study, directory: str, sweep_spec: dict) -> str:
  """Draws ``curves.png`` and writes ``ablation.md`` for the arms of ``sweep_spec`` evaluated under
  ``directory``."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  from blx.experiments import sweep
  arms, curves = {}, {}
  for name, _ in sweep.expand(sweep_spec):
    path = os.path.join(directory, name)
    if not os.path.exists(os.path.join(path, "eval.json")):
      continue
    with open(os.path.join(path, "eval.json")) as f:
      arms[name] = json.load(f)
    with open(os.path.join(path, "metrics.csv")) as f:
      curves[name] = list(csv.DictReader(f))
  if not arms:
    raise SystemExit(f"{directory}: no evaluated arm of {study_name} yet")
  fig, axes = plt.subplots(1, len(study.metrics), figsize=(5 * len(study.metrics), 3.6),
                           squeeze=False)
  for ax, key in zip(axes[0], study.metrics):
    for name, rows in curves.items():
      steps, mean, std = curve(rows, key)
      if not steps:
        continue
      x = [s / 1e6 for s in steps]
      ax.plot(x, mean, label=name.replace("__", ", "))
      ax.fill_between(x, [m - s for m, s in zip(mean, std)], [m + s for m, s in zip(mean, std)],
                      alpha=0.2)
    ax.set_xlabel("env steps per seed (millions)")
    ax.set_title(LABELS.get(key, key))
    ax.grid(alpha=0.3)
  axes[0][0].legend(fontsize=7)
  fig.suptitle(f"{study_name}; the paper: {study.claim} (mean ± std over seeds)", fontsize=9)
  fig.tight_layout()
  fig.savefig(os.path.join(directory, "curves.png"), dpi=120)
  plt.close(fig)
  table = "\n".join(compare(arms, study.metrics))
  with open(os.path.join(directory, "ablation.md"), "w") as f:
    f.write(f"# {study_name}\n\nThe paper: {study.claim}.\n\n{table}\n")
  return table


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("study", nargs="?", choices=sorted(STUDIES))
  parser.add_argument("--list", action="store_true", help="print the studies and their arms")
  parser.add_argument("--env", choices=paper_tables.ENVS, default="ant")
  parser.add_argument("--seeds", type=int, default=10)
  parser.add_argument("--steps", type=int, default=None,
                      help="env steps per seed (default the paper's: the env's PPO row x 2)")
  parser.add_argument("--arm", action="append", default=None, metavar="VALUE",
                      help="train only the arms with this value (JSON, e.g. false or 10.0)")
  parser.add_argument("--out", default="sweeps/ablations")
  parser.add_argument("--report", action="store_true", help="only draw and tabulate")
  args = parser.parse_args()
  if args.list or args.study is None:
    for name, s in STUDIES.items():
      print(f"{name}: {', '.join(s.objectives)} x {s.option} in {list(s.values)} -- {s.claim}")
    return
  from blx.experiments import sweep
  study = STUDIES[args.study]
  directory = os.path.join(args.out, f"{args.study}_{args.env}")
  sweep_spec = spec(study, args.env, args.seeds, args.steps)
  if not args.report:
    only = None
    if args.arm:
      only = [json.loads(v) for v in args.arm]
      bad = [v for v in only if v not in study.values]
      if bad:
        parser.error(f"--arm {bad}: {args.study}'s values are {list(study.values)}")
    select = None if only is None else (
        lambda name, run_spec: run_spec.objective_options[study.option] in only)
    sweep.run_sweep(sweep_spec, directory, select=select, eval_metrics=True)
  print(report(args.study, study, directory, sweep_spec))


if __name__ == "__main__":
  main()
