"""The paper's ablations (#15), each one command: arms that differ in one setting from the paper's
row, trained with the row's protocol, compared by curves and by a Welch test against the first arm.

    python benchmarks/ablations.py STUDY [--env ant|humanoid|halfcheetah] [--seeds 10]
                                         [--out sweeps/ablations] [--steps N] [--arm VALUE]
                                         [--objective NAME] [--config JSON]
                                         [--reference NAME=PATH ...]
                                         [--eval-protocol quick|final]
    python benchmarks/ablations.py STUDY --report    # only the curves and table of what has run

Studies (``--list`` prints them):
- ``sn_diayn``: DIAYN with spectral norm (the paper's row) and without (the paper: SN helps, on Ant
  and Humanoid);
- ``sn_cdiayn``: the same for cDIAYN;
- ``gp``: AIRL and GAIL with gradient penalty weight 0 (the paper's rows), 1 and 10 (the paper: no
  significant gain; too much penalty hurts). The paper does not give its weights; these are ours;
- ``skills``: DIAYN with 2, 4, 8 (the paper's row) and 16 skills;
- ``run_reward``: DIAYN on the xy velocity with the ant's own running reward added
  (``env_reward_multiplier`` 0, the row, and 1): distinct gaits that all run;
- ``step_diayn``, ``step_gail`` (HalfCheetah only; not the paper's): DIAYN and GAIL at blx's
  half-cheetah step (16 substeps of 3.125 ms) and at 8 substeps of 6.25 ms (``env_params.edits``),
  both with 4 Newton iterations: whether the step ``cheetah_step.py`` found about twice as fast
  learns the same at the same env steps (``--steps`` below the paper's fits a device call);
- ``push_scale``, ``legs`` (the paper's Composer sweeps, ``--env ant``): the task reward of
  ``ant_push`` with the ball's velocity term scaled by 1 (the env's default), 0.2 and 0.5, and of
  ``pro_ant_run(step="blx")`` with 4 (the registered env's), 2, 3, 8 and 10 legs, compared by
  episode score (the paper: Ant Push is sensitive to the scale; running is consistent except with
  two legs), with the episode length and, during training, the env reward per step of the
  training rollouts beside it (an evaluation's episodes are one episode where the reset has no
  noise). The original's sweeps at the paper's commit trained each point for the ant's PPO row
  (30 M steps, ``ant_push_sweep.py``) and the row x 10 (300 M, ``ant_run_morphology_sweep.py``);
  ``--steps`` trains another budget, and the report then says so. ``legs`` runs blx's faster step
  (4 substeps of 5 ms), the env's default until session 28;
- ``legs_original``: the leg-count sweep at the original's physics step (``pro_ant_run``'s
  ``step="original"``, 16 substeps of 1.25 ms, the env's default since session 28; 3.3 to 3.9
  times the cost per env step), where three legs run markedly better (RESULTS, sessions 27, 28);
- ``legs_step`` (``--env ant``; not the paper's): the three-legged ``pro_ant_run`` at blx's step (4
  substeps of 5 ms) and at the original's (16 of 1.25 ms), the same 0.02 s control step: whether
  the step is why three legs fall short of the paper (RESULTS, session 26).

Each arm is a point of one ``blx sweep`` (``benchmarks/paper_tables.py`` gives the row's settings),
trained with ``--eval-metrics`` so that MI, H(s) or the energy distance is logged at every
evaluation (4 episodes, or the final evaluation's 10 with ``--eval-protocol final``: such an
arm's label says so, since its curves are not comparable with a quick one's). Points already
evaluated are reused, so ``--arm`` (and, in a study of several objectives, ``--objective``) lets
one process per GPU train one arm and a last call (``--report``) draws them together. Writes
``OUT/STUDY_ENV/``: the sweep's run directories, ``curves.png`` (each metric against env steps,
mean and std over seeds per arm) and ``ablation.md`` (each arm's final metrics, mean +- std over
seeds, Welch's t-test against the first arm; the wall time to the first arm's last mean and, where
the paper reports the arm's objective, to the paper's mean, on the curve of Braxlines' window
where the run logged it). ``--reference NAME=PATH`` adds another run trained
with ``--eval-metrics`` (its directory or metrics.csv; e.g. a finished row trained with another
setting; up to three, each its own ``--reference``): its curve is drawn over the arms' span, and
each arm's last evaluation is tested against the reference's at the same env steps. So an arm run
for a fraction of a row's steps is compared with the row where the row was. Where the reference
has its eval.json, each arm's final evaluation is also tested against it: so a study whose row has
run before (``--arm`` the other values) is compared with that row. A reference trained without
``--eval-metrics`` (the Humanoid DIAYN row, the SN arm of ``sn_diayn --env humanoid``) has no
curves: it is drawn as its final evaluation, a point, beside each finished arm's own (the arms'
curves may use another protocol than the final evaluation's), and compared by its eval.json only. A
reference whose config.json names an objective faces only that objective's arms (the AIRL row,
the AIRL arms).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import sys
import textwrap

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import paper_tables  # noqa: E402

from blx.envs.descs import PRO_ANT_STEPS  # noqa: E402
from blx.experiments import cli, runs  # noqa: E402
from blx.metrics import mode_balance  # noqa: E402
from blx.training import config as ppo_config  # noqa: E402


@dataclasses.dataclass(frozen=True)
class Study:
  """Arms that differ from the paper's row of ``family`` in one setting: ``option`` of the spec's
  ``group`` (``"options"``, the objective's options, or ``"env_params"``, the env's parameters).
  The first value is the row's own."""

  family: str                  # the paper_tables family whose settings every arm shares
  objectives: tuple[str, ...]
  option: str
  values: tuple
  metrics: tuple[str, ...]     # eval.json / metrics.csv keys; compared at the last evaluation
  claim: str                   # the conclusion tested (the paper's, unless ``paper`` is off)
  group: str = "options"
  envs: tuple[str, ...] | None = None   # the envs the study is defined for (None: every one)
  labels: tuple[str, ...] | None = None  # legend names of the values (default: the arm's name)
  paper: bool = True           # whether ``claim`` is the paper's
  scene: str | None = None     # the Composer env of a "task" study's arms (else ``--env``)
  multiplier: int = 2          # the original's env steps per seed: the PPO row times this
  scene_params: dict | None = None  # env parameters every arm of a "task" study gives ``scene``

  def label(self, name: str, run_spec) -> str:
    """An arm's legend entry: its sweep point's name, or where ``labels`` are given, the value's
    label (after the objective's name when the study has several)."""
    if self.labels is None:
      return name.replace("__", ", ")
    label = self.labels[self.values.index(self.value(run_spec))]
    return f"{run_spec.objective}, {label}" if len(self.objectives) > 1 else label

  def style(self, run_spec) -> tuple[str, str]:
    """An arm's colour and line style in the curves: the colour is its value's and the line its
    objective's (solid, dashed, dash-dot), so that the arms of one value read as a pair."""
    return (f"C{self.values.index(self.value(run_spec)) % 10}",
            OBJECTIVE_STYLES[self.objectives.index(run_spec.objective)])

  def default_steps(self, env: str) -> int:
    """The original's env steps per seed: the PPO row of the arms' env times ``multiplier``."""
    return self.multiplier * paper_tables.ppo_defaults(self.scene or env).num_timesteps

  @property
  def claim_line(self) -> str:
    """The claim tested, and whose it is; and the env parameters the arms share, where they do."""
    line = f"{'the paper' if self.paper else 'tested (not a claim of the paper)'}: {self.claim}"
    if self.scene_params:
      shared = ", ".join(f"{k}={v!r}" for k, v in self.scene_params.items())
      line += f"; every arm: {self.scene}({shared})" + (" before its edits"
                                                        if self.option == "edits" else "")
    return line

  def settings(self, run_spec) -> dict:
    """The dict of one arm's ``runs.RunSpec`` that the studied setting lives in."""
    return run_spec.objective_options if self.group == "options" else run_spec.env_params

  def value(self, run_spec) -> object:
    """The studied setting's value in one arm's ``runs.RunSpec`` (the row's, ``values[0]``,
    where the arm leaves it at its default)."""
    return self.settings(run_spec).get(self.option, self.values[0])


# The half-cheetah's cheaper step (``benchmarks/cheetah_step.py``, session 18): 8 substeps of
# 6.25 ms with blx's 4 Newton iterations instead of 16 of 3.125 ms, the same 50 ms env step.
CHEETAH_FAST_STEP = {"global_options.timestep": 0.00625, "global_options.substeps": 8}
_STEP_CLAIM = "8 substeps of 6.25 ms learn what blx's 16 of 3.125 ms learn, at the same env steps"
_STEP_LABELS = ("blx's step: 16 x 3.125 ms", "8 x 6.25 ms")

# The original's pro_ant_run step, 16 substeps of 1.25 ms, where blx's steps 4 of 5 ms (the same
# 0.02 s): on three legs, which fall short of the paper at blx's step. The arms are edits of
# ``pro_ant_run(step="blx")`` rather than the env's ``step`` parameter: the edits name the run
# directories of the study's first run (session 26, when blx's step was the env's default).
_THREE_LEGS = {"components.agent1.component_params.num_legs": 3}
PRO_ANT_ORIGINAL_STEP = {f"global_options.{k}": v for k, v in PRO_ANT_STEPS["original"].items()}
# A Composer task's score sums a per-step term, so an episode cut short by a fall scores higher:
# the length is read beside it.
# A task study's evaluation takes the mean action from a reset without noise: a seed's episodes are
# one episode repeated, which can dip for one evaluation; the training reward (the sampled policy
# over every env, each chunk) is tabulated and drawn beside it (RESULTS, session 57). Not the
# paper's metric, and not in eval.json: the final evaluations compare the first two alone.
_TASK_METRICS = ("eval/episode_score", "eval/episode_length", "train/env_reward")

STUDIES = {
    "sn_diayn": Study("mimax", ("diayn",), "spectral_norm", (True, False),
                      ("eval/mi", "eval/entropy", "eval/lgr"),
                      "spectral norm improves DIAYN's MI and H(s)"),
    "sn_cdiayn": Study("mimax", ("cdiayn",), "spectral_norm", (True, False),
                       ("eval/mi", "eval/entropy", "eval/lgr"),
                       "spectral norm makes cDIAYN's skills distinct"),
    "gp": Study("dmin", ("airl", "gail"), "gradient_penalty_weight", (0.0, 1.0, 10.0),
                ("eval/energy_distance", "eval/mode_balance"),
                "gradient penalty does not help much; too much hurts",
                labels=("no penalty (the paper's row)", "penalty weight 1", "penalty weight 10")),
    "skills": Study("mimax", ("diayn",), "num_skills", (8, 2, 4, 16),
                    ("eval/mi", "eval/entropy", "eval/lgr"),
                    "more skills raise the MI, which is bounded by ln K", paper=False),
    "run_reward": Study("mimax", ("diayn",), "env_reward_multiplier", (0.0, 1.0),
                        ("eval/mi", "eval/entropy", "eval/episode_env_reward"),
                        "with the run reward, skills are gaits that all run"),
    "step_diayn": Study("mimax", ("diayn",), "edits", ({}, CHEETAH_FAST_STEP),
                        ("eval/mi", "eval/entropy", "eval/lgr"), _STEP_CLAIM,
                        group="env_params", envs=("halfcheetah",), labels=_STEP_LABELS,
                        paper=False),
    "step_gail": Study("dmin", ("gail",), "edits", ({}, CHEETAH_FAST_STEP),
                       ("eval/energy_distance",), _STEP_CLAIM,
                       group="env_params", envs=("halfcheetah",), labels=_STEP_LABELS,
                       paper=False),
    "push_scale": Study("task", ("task",), "goal_scale", (1.0, 0.2, 0.5), _TASK_METRICS,
                        "Ant Push's score is sensitive to the scale of the ball's velocity term",
                        group="env_params", envs=("ant",), scene="ant_push", multiplier=1,
                        labels=("scale 1 (the env's)", "scale 0.2", "scale 0.5")),
    "legs": Study("task", ("task",), "num_legs", (4, 2, 3, 8, 10), _TASK_METRICS,
                  "running is consistent across leg counts except with two legs",
                  group="env_params", envs=("ant",), scene="pro_ant_run", multiplier=10,
                  scene_params={"step": "blx"},
                  labels=("4 legs (the env's)", "2 legs", "3 legs", "8 legs", "10 legs")),
    "legs_original": Study("task", ("task",), "num_legs", (4, 2, 3, 8, 10), _TASK_METRICS,
                           "running is consistent across leg counts except with two legs",
                           group="env_params", envs=("ant",), scene="pro_ant_run", multiplier=10,
                           scene_params={"step": "original"},
                           labels=("4 legs (the env's)", "2 legs", "3 legs", "8 legs", "10 legs")),
    "legs_step": Study("task", ("task",), "edits",
                       (_THREE_LEGS, {**_THREE_LEGS, **PRO_ANT_ORIGINAL_STEP}), _TASK_METRICS,
                       "three legs run as well at the original's 16 x 1.25 ms step as at blx's "
                       "4 x 5 ms", group="env_params", envs=("ant",), scene="pro_ant_run",
                       multiplier=10, paper=False, scene_params={"step": "blx"},
                       labels=("3 legs, blx's step: 4 x 5 ms", "3 legs, 16 x 1.25 ms")),
}


LABELS = {"eval/mi": "MI(s, z)", "eval/entropy": "H(s)", "eval/lgr": "LGR (lower is better)",
          "eval/energy_distance": "energy distance (lower is better)",
          "eval/episode_env_reward": "episode env reward",
          "eval/episode_score": "episode score (the reward without its offsets)",
          "eval/episode_length": "episode length (steps; short: the body fell)",
          "train/env_reward": "env reward per step in training\n(sampled actions, every env)",
          "eval/mode_balance": "mode balance (1: an even split; 0: one mode)"}


def spec(study: Study, env: str, seeds: int, steps: int | None = None,
         config: dict | None = None) -> dict:
  """One sweep over the study's objectives x values, on the settings of the paper's row (with the
  PPO settings ``config`` over the row's, e.g. ``num_evals``, for every arm)."""
  if study.envs is not None and env not in study.envs:
    raise ValueError(f"env {env!r}: this study is defined for {list(study.envs)}")
  if study.family == "task":  # a Composer sweep: the scene's task reward, the ant's PPO row
    base = dict(env=study.scene, seeds=list(range(seeds)), options={},
                env_params=dict(study.scene_params or {}),
                steps=study.default_steps(env) if steps is None else steps,
                config=dict(config or {}))
  else:
    base = paper_tables.specs(seeds, steps=steps, env=env, config=config)[study.family]
  varied = dict(base[study.group])
  varied[study.option] = list(study.values)
  return dict(base, name=f"ablation_{study.option}_{env}", objective=list(study.objectives),
              **{study.group: varied})


BALANCE = "eval/mode_balance"


def _shares(get) -> list | None:
  """The modes' sample shares ``eval/mode_share/0, 1, ...`` that ``get(key)`` finds, or None."""
  shares = []
  while get(f"eval/mode_share/{len(shares)}") not in (None, ""):
    shares.append(get(f"eval/mode_share/{len(shares)}"))
  return shares or None


def with_mode_balance(rows: list[dict]) -> list[dict]:
  """metrics.csv rows with ``eval/mode_balance`` (``blx.metrics.mode_balance`` of the modes' shares)
  where a run trained before blx logged it (session 31) logged the shares."""
  out = []
  for row in rows:
    shares = _shares(row.get)
    if shares and row.get(BALANCE) in (None, ""):
      row = {**row, BALANCE: float(mode_balance([float(v) for v in shares]))}
    out.append(row)
  return out


def final_with_mode_balance(result: dict) -> dict:
  """An eval.json with ``eval/mode_balance`` per seed, as ``with_mode_balance`` for its rows."""
  per_seed = result.get("per_seed", {})
  shares = _shares(per_seed.get)
  if not shares or BALANCE in per_seed:
    return result
  balance = mode_balance([[float(v) for v in seed] for seed in zip(*shares)])
  return {**result, "per_seed": {**per_seed, BALANCE: [float(b) for b in balance]}}


# The LGR's keys. One scored on other goals than the paper's (blx's evaluators drew other goals
# before session 41: ``paper_tables.OTHER_GOALS``) moves to ``other_goals(key)``, a metric of its
# own, so that no curve, table or test sets it beside an LGR on the paper's goals.
LGR_KEYS = ("eval/lgr", "eval/lgr_braxlines")


def other_goals(key: str) -> str:
  """The key an LGR ``key`` scored on other goals than the paper's is kept under."""
  return key + paper_tables.OTHER_GOALS


def with_other_goals(metrics: tuple[str, ...]) -> tuple[str, ...]:
  """``metrics`` with each LGR key followed by ``other_goals`` of it: the keys a table covers."""
  return tuple(k for key in metrics for k in ((key, other_goals(key)) if key in LGR_KEYS
                                                 else (key,)))


def with_lgr_goals(rows: list[dict], segments: list[runs.Segment] | tuple) -> list[dict]:
  """metrics.csv rows with each LGR that was not scored on the paper's goals moved to
  ``other_goals`` of its key: the run's provenance segment that logged it
  (``runs.segment_at``) does not say "braxlines", or no segment did (steps trained before blx
  recorded provenance, whose goals were blx's old ones)."""
  out = []
  for row in rows:
    segment = runs.segment_at(segments, float(row["env_steps"]))
    if (any(row.get(k) not in (None, "") for k in LGR_KEYS)
        and (segment is None or segment.lgr_goals != "braxlines")):
      row = {other_goals(k) if k in LGR_KEYS else k: v for k, v in row.items()}
    out.append(row)
  return out


def final_with_lgr_goals(result: dict) -> dict:
  """An eval.json with its LGR moved to ``other_goals`` of its key where it was not scored on the
  paper's goals (``evaluated_on``'s ``lgr_goals`` is not "braxlines", or it is not recorded)."""
  per_seed = result.get("per_seed", {})
  if ((result.get("evaluated_on") or {}).get("lgr_goals") == "braxlines"
      or not any(k in per_seed for k in LGR_KEYS)):
    return result
  return {**result, "per_seed": {other_goals(k) if k in LGR_KEYS else k: v
                                 for k, v in per_seed.items()}}


def final_lgr_and_balance(result: dict) -> dict:
  """An eval.json as the reports read it: ``final_with_lgr_goals`` of
  ``final_with_mode_balance``."""
  return final_with_lgr_goals(final_with_mode_balance(result))


def by_step(rows: list[dict], key: str) -> dict[float, dict[int, float]]:
  """``{env steps: {seed: value}}`` of ``key`` in metrics.csv rows (rows without a finite value
  left out)."""
  values: dict[float, dict[int, float]] = {}
  for row in rows:
    value = row.get(key)
    if value not in (None, "") and math.isfinite(float(value)):
      values.setdefault(float(row["env_steps"]), {})[int(float(row["seed"]))] = float(value)
  return values


def complete_steps(values: dict[float, dict[int, float]]) -> list[float]:
  """The env steps of ``by_step``'s result at which every seed has a value, in order."""
  seeds = max((len(v) for v in values.values()), default=0)
  return sorted(s for s, v in values.items() if len(v) == seeds)


def curve(rows: list[dict], key: str) -> tuple[list[float], list[float], list[float]]:
  """``(env steps, mean, std)`` over seeds of ``key`` in metrics.csv rows, at every evaluation
  where every seed has a value."""
  values = by_step(rows, key)
  steps = complete_steps(values)
  seeds = len(values[steps[0]]) if steps else 0
  mean = [sum(values[s].values()) / seeds for s in steps]
  std = [math.sqrt(sum((x - m) ** 2 for x in values[s].values()) / seeds)
         for s, m in zip(steps, mean)]
  return steps, mean, std


def welch_cells(values, ref) -> list[str]:
  """The two table cells of Welch's t-test of ``values`` against ``ref``: t, and p with three
  decimals or "< 0.001" below that; both empty where either side has fewer than 2 values, and
  "no spread" where both sides are constant (every episode of both arms ran 1,000 steps), which
  the test cannot tell apart."""
  from scipy import stats
  if not (values and ref and len(values) > 1 and len(ref) > 1):
    return ["", ""]
  if len(set(values)) == 1 and len(set(ref)) == 1:
    return ["", "equal, no spread" if values[0] == ref[0] else "no spread"]
  test = stats.ttest_ind(values, ref, equal_var=False)
  return [f"{test.statistic:+.2f}",
          "< 0.001" if test.pvalue < 0.001 else f"{test.pvalue:.3f}"]


def compare(arms: dict[str, dict], metrics: tuple[str, ...]) -> list[str]:
  """Markdown rows: per arm and metric, mean +- std over seeds, and Welch's t-test against the
  first arm of the same objective. ``arms``: ``{name: eval.json}``."""
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
      ref = arms[reference]["per_seed"].get(key) if name != reference else None
      t, p = welch_cells(values, ref)
      rows.append(f"| {name} | {key} | {mean:.3f} ± {std:.3f} ({n}) | {t} | {p} |")
  return rows


def against(curves: dict[str, list[dict]], name: str, reference: list[dict],
            metrics: tuple[str, ...]) -> list[str]:
  """Markdown rows: each arm's last evaluation in its metrics.csv (where every seed has a value)
  against the evaluation of ``reference`` (another run's metrics.csv rows, e.g. a finished row's)
  at the same env steps, Welch's t-test. Where the reference was not evaluated at the arm's last
  steps (another evaluation grid), the last steps both were evaluated at, named beside the arm's
  last. ``curves``: ``{arm label: metrics.csv rows}``."""
  rows = [f"| arm | metric | env steps | arm: mean ± std (seeds) | {name}: mean ± std (seeds) "
          "| Welch t | p |", "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
  ref_by_key = {key: by_step(reference, key) for key in metrics}
  for label, arm_rows in curves.items():
    for key in metrics:
      arm_by_step = by_step(arm_rows, key)
      steps = complete_steps(arm_by_step)
      if not steps:
        continue
      ref_by_step = ref_by_key[key]
      shared = [s for s in steps if ref_by_step.get(s)]
      step = shared[-1] if shared else steps[-1]
      values = list(arm_by_step[step].values())
      mean, std = paper_tables.mean_std(values)
      at = f"{step / 1e6:.2f} M" + ("" if step == steps[-1] else
                                    f" (the arm's last: {steps[-1] / 1e6:.2f} M)")
      cells = [label, key, at, f"{mean:.3f} ± {std:.3f} ({len(values)})"]
      ref = list(ref_by_step.get(step, {}).values())
      if not ref_by_step:  # e.g. an LGR the reference scored on other goals only
        cells += [f"no {key}", "", ""]
      elif not ref:
        near = sorted(ref_by_step, key=lambda s: abs(s - step))[:2]
        cells += [f"no evaluation at {step / 1e6:.2f} M (nearest: "
                  f"{', '.join(f'{s / 1e6:.2f} M' for s in sorted(near)) or 'none'})", "", ""]
      else:
        ref_mean, ref_std = paper_tables.mean_std(ref)
        cells.append(f"{ref_mean:.3f} ± {ref_std:.3f} ({len(ref)})")
        cells += welch_cells(values, ref)
      rows.append("| " + " | ".join(cells) + " |")
  return rows


def during(curves: dict[str, tuple[str, list[dict]]], metrics: tuple[str, ...]) -> list[str]:
  """Markdown rows: per arm and metric, its evaluation during training at the last env steps at
  which every arm has every seed evaluated, and Welch's t-test against the first arm of the same
  objective: a study compared while an arm is unfinished. ``curves``: ``{arm label: (objective,
  metrics.csv rows)}``."""
  rows = ["| arm | metric | env steps | mean ± std (seeds) | Welch t vs first | p |",
          "| --- | --- | ---: | ---: | ---: | ---: |"]
  first: dict[str, str] = {}
  for key in metrics:
    by_arm = {label: by_step(arm_rows, key) for label, (_, arm_rows) in curves.items()}
    shared = (set.intersection(*(set(complete_steps(b)) for b in by_arm.values())) if by_arm
              else set())
    if not shared:
      continue
    step = max(shared)
    for label, (objective, _) in curves.items():
      values = list(by_arm[label][step].values())
      reference = first.setdefault(objective, label)
      mean, std = paper_tables.mean_std(values)
      t, p = welch_cells(values, list(by_arm[reference][step].values())
                         if label != reference else None)
      rows.append(f"| {label} | {key} | {step / 1e6:.2f} M | {mean:.3f} ± {std:.3f} "
                  f"({len(values)}) | {t} | {p} |")
  return rows


# +1: a larger value is better, -1: a smaller; the metrics whose wall time to a target is tabulated.
BETTER = {"eval/mi": 1, "eval/entropy": 1, "eval/lgr": -1, other_goals("eval/lgr"): -1,
          "eval/energy_distance": -1, "eval/episode_env_reward": 1, "eval/episode_score": 1}


def ran_on(segments: list[runs.Segment]) -> str:
  """The devices a run trained on, in order (``runs.read_provenance``), e.g. "NVIDIA H200, then
  NVIDIA H100 80GB HBM3"; "not recorded" for a run from before blx recorded them, and for the env
  steps a run took before it did (a run begun by an older blx and resumed by a newer one):
  "not recorded to 37.4 M steps, then NVIDIA H200". A process that kept no env steps (one that
  stopped or failed before its first checkpoint, or evaluated a finished run) is left out."""
  kinds, reached = [], 0.0
  for segment in segments:
    if segment.to_env_steps <= segment.from_env_steps:
      continue
    if segment.from_env_steps > reached:
      stretch = (f"from {reached / 1e6:.1f} M " if reached else "") + \
          f"to {segment.from_env_steps / 1e6:.1f} M steps"
      kinds.append(f"not recorded {stretch}")
    kind = segment.device + (f" x {segment.device_count}" if segment.device_count > 1 else "")
    if not kinds or kinds[-1] != kind:
      kinds.append(kind)
    reached = max(reached, segment.to_env_steps)
  return ", then ".join(kinds) or "not recorded"


def _reached(rows: list[dict], steps: list[float], mean: list[float], sign: float,
             target: float) -> str:
  """Two table cells: the env steps at which ``mean`` (a curve of ``rows``, at ``steps``) first
  reaches ``target`` (``sign`` 1: from below, -1: from above) and the run's wall time there
  (metrics.csv's ``time``; "not recorded" where the row has none); "not reached" and an empty
  cell where it never does."""
  hit = next((s for s, m in zip(steps, mean) if sign * (m - target) >= 0), None)
  if hit is None:
    return "not reached | "
  wall = {float(r["env_steps"]): float(r["time"]) for r in rows if r.get("time")}
  return f"{hit / 1e6:.2f} M | " + (f"{wall[hit]:,.0f} s" if hit in wall else "not recorded")


def time_to(curves: dict[str, tuple[str, list[dict]]], metrics: tuple[str, ...],
            devices: dict[str, str] | None = None) -> list[str]:
  """Markdown rows: per metric of ``BETTER``, the first arm's (of each objective) last evaluation
  during training, mean over seeds, is the target; per arm, the env steps and wall time
  (metrics.csv's ``time``: seconds since the run's start, compilation and evaluations included) at
  which its mean first reaches the target, or "not reached". Where arms cost differently per env
  step (a finer physics step), this is what the study's user waits. ``curves``: ``{arm label:
  (objective, metrics.csv rows)}``; ``devices``, where given, ``{arm label: ran_on(...)}`` for a
  last column, since wall times compare only on like devices."""
  rows = ["| arm | metric | target (first arm's last) | env steps | wall time |"
          + (" ran on |" if devices else ""),
          "| --- | --- | ---: | ---: | ---: |" + (" --- |" if devices else "")]
  for key in (k for k in metrics if k in BETTER):
    sign, targets = BETTER[key], {}
    for label, (objective, arm_rows) in curves.items():
      steps, mean, _ = curve(arm_rows, key)
      if not steps:
        continue
      target = targets.setdefault(objective, mean[-1])
      cells = _reached(arm_rows, steps, mean, sign, target)
      rows.append(f"| {label} | {key} | {target:.3f} | {cells} |"
                  + (f" {devices.get(label, 'not recorded')} |" if devices else ""))
  return rows


def paper_value(env: str, objective: str, key: str) -> float | None:
  """The paper's mean of ``key`` for ``objective`` on ``env`` (``paper_tables.PAPER``, which keeps
  a lower-is-better metric negated), or None where the paper gives none."""
  row = paper_tables.PAPER.get(env, {}).get(objective, {})
  if key in row:
    return row[key][0]
  return -row[f"-{key}"][0] if f"-{key}" in row else None


def paper_window_curve(rows: list[dict], key: str) -> tuple[str, tuple[list, list, list]]:
  """``(window, curve(rows, ...))`` of ``key``: in Braxlines' window (``KEY_braxlines``, where the
  paper's numbers were taken) where the run logged it, else in blx's; ``window`` names which
  ("Braxlines'" or "blx's")."""
  braxlines = curve(rows, f"{key}_braxlines")
  return ("Braxlines'", braxlines) if braxlines[0] else ("blx's", curve(rows, key))


def time_to_paper(curves: dict[str, tuple[str, list[dict]]], env: str, metrics: tuple[str, ...],
                  devices: dict[str, str] | None = None) -> list[str]:
  """Markdown rows: per metric of ``BETTER`` and arm whose objective the paper reports on ``env``,
  the env steps and wall time (as :func:`time_to`) at which the arm's mean over seeds first reaches
  the paper's mean, or "not reached". The curve is that of Braxlines' window (``KEY_braxlines``,
  where the paper's numbers were taken) where the run logged it, else blx's window, and the row
  names which. ``curves`` and ``devices`` as :func:`time_to`; no rows where the paper gives no
  value for any arm."""
  rows = []
  for key in (k for k in metrics if k in BETTER):
    for label, (objective, arm_rows) in curves.items():
      target = paper_value(env, objective, key)
      if target is None:
        continue
      window, (steps, mean, _) = paper_window_curve(arm_rows, key)
      if not steps:
        continue
      cells = _reached(arm_rows, steps, mean, BETTER[key], target)
      rows.append(f"| {label} | {key} | {window} | {target:.3f} | {cells} |"
                  + (f" {devices.get(label, 'not recorded')} |" if devices else ""))
  if not rows:
    return []
  return (["| arm | metric | window | the paper's | env steps | wall time |"
           + (" ran on |" if devices else ""),
           "| --- | --- | --- | ---: | ---: | ---: |" + (" --- |" if devices else "")] + rows)


def budget_line(study: Study, sweep_spec: dict, trained: float | None = None) -> str:
  """The arms' env steps per seed, and the original's where the arms ran another budget.
  ``trained``, the env steps the finished arms reached, is named where it is not the budget asked
  (PPO rounds the budget up to whole iterations in each evaluation chunk)."""
  steps, original = int(sweep_spec["steps"]), study.default_steps(sweep_spec["env"])
  line = f"Env steps per seed: {steps / 1e6:g} M"
  if steps == original:
    line += " (the original's)"
  else:
    budget = "shorter" if steps < original else "longer"
    line += f"; the original's: {original / 1e6:g} M (a {budget} budget)"
  if trained is not None and abs(trained - steps) > 1e-3 * steps:
    line += f"; {trained / 1e6:.2f} M trained (whole PPO iterations per evaluation chunk)"
  return line + "."


@dataclasses.dataclass(frozen=True)
class Reference:
  """Another run the arms are compared with (``--reference``), e.g. a finished row."""

  name: str
  rows: list[dict]            # its metrics.csv: the evaluations during training
  final: dict | None = None   # its eval.json (the paper's protocol after training), if it has one
  segments: tuple = ()        # where it trained (``runs.read_provenance``), if recorded
  objective: str | None = None  # its objective (config.json's), if known: it faces only those arms


def facing(reference: Reference, objectives: dict[str, str]) -> list[str]:
  """The arms (keys of ``objectives``, ``{arm: objective}``) that ``reference`` is compared with:
  those of its own objective where it names one that an arm has (the AIRL row against the AIRL
  arms, not the GAIL ones); else every arm."""
  own = [arm for arm, objective in objectives.items() if objective == reference.objective]
  return own if reference.objective is not None and own else list(objectives)


def read_reference(name: str, path: str, metrics: tuple[str, ...]) -> Reference:
  """The run at ``path`` (a run directory or its metrics.csv) as a ``Reference``, with the
  eval.json beside its metrics.csv where there is one. A run that logged none of ``metrics``
  during training (one trained without ``--eval-metrics``, as the Humanoid DIAYN row) is taken
  where its eval.json scores one of them: such a reference is compared by final evaluations only
  (``logs_curves``); one with neither is refused. A run's files committed under a prefix, as the
  paper's rows in ``benchmarks/paper/`` (``airl_metrics.csv``), take the eval.json and the
  provenance of their prefix (``airl_eval.json``, ``airl_provenance.json``). An LGR not scored on
  the paper's goals is kept under ``other_goals`` of its key (``with_lgr_goals``)."""
  csv_path = os.path.join(path, "metrics.csv") if os.path.isdir(path) else path
  if not os.path.isfile(csv_path):
    raise ValueError(f"{path}: not a run directory with metrics.csv, nor a metrics.csv file")
  with open(csv_path) as f:
    rows = with_mode_balance(list(csv.DictReader(f)))
  final, base = None, os.path.basename(csv_path)
  prefix = base[:-len("metrics.csv")] if base.endswith("metrics.csv") else None
  eval_path = os.path.join(os.path.dirname(csv_path), f"{prefix}eval.json")
  if prefix is not None and os.path.isfile(eval_path):
    with open(eval_path) as f:
      final = final_lgr_and_balance(json.load(f))
  scored = [key for key in with_other_goals(metrics) if key in (final or {}).get("per_seed", {})]
  if not any(by_step(rows, key) for key in metrics) and not scored:
    raise ValueError(f"{csv_path}: logs none of {list(metrics)} during training (train it with "
                     "--eval-metrics), and has no eval.json beside it that scores one of them")
  segments = (runs.read_provenance(os.path.dirname(csv_path), f"{prefix}{runs.PROVENANCE}")
              if prefix is not None else [])
  rows = with_lgr_goals(rows, segments)
  objective = (final or {}).get("objective")
  config_path = os.path.join(os.path.dirname(csv_path), f"{prefix}config.json")
  if prefix is not None and os.path.isfile(config_path):
    with open(config_path) as f:
      objective = json.load(f).get("objective", objective)
  return Reference(name, rows, final, tuple(segments),
                   objective if isinstance(objective, str) else None)


def logs_curves(reference: Reference, metrics: tuple[str, ...]) -> bool:
  """Whether ``reference`` logged any of ``metrics`` during training: one that did not (trained
  without ``--eval-metrics``) is drawn as its final evaluation, a point at the env steps it
  trained, and compared by that alone."""
  return any(by_step(reference.rows, key) for key in metrics)


def reference_steps(reference: Reference) -> float:
  """The env steps per seed ``reference`` trained (its metrics.csv's last; 0 where none)."""
  return max((float(r["env_steps"]) for r in reference.rows if r.get("env_steps")), default=0.0)


REFERENCE_STYLES = ("--", ":", "-.")  # one line style per reference, all dark grey
OBJECTIVE_STYLES = ("-", "--", "-.")  # one line style per objective of a study, in its colours


def _timed(rows: list[dict]) -> bool:
  """Whether a run's metrics.csv rows all carry its wall time (``time``), as blx's runs log it."""
  return all(row.get("time") for row in rows)


def _other_settings(path: str, run_spec: runs.RunSpec, *, returns: bool = True) -> str:
  """What a label adds where the run in ``path`` was trained with PPO settings other than the
  report's: " (a 10 M budget)" for another budget (an arm of an earlier, shorter report, kept until
  its rerun finishes), " (trained with entropy_cost=0.1)" for any other setting (e.g. a report
  drawn without the ``--config`` its arms trained with); else "". What the run trained with is
  every setting its provenance recorded, else its config.json's (``runs.settings_as_trained``):
  a setting it took from a default that moved since is named too ("eval_actions='mean'"). With
  ``returns`` False (a study none of whose metrics is a return episode's, ``eval/episode_*``), the
  settings of the return episodes alone (``ppo_config.RETURN_SETTINGS``) are left out."""
  if not os.path.exists(os.path.join(path, "config.json")):
    return ""
  spec = runs.read_spec(path)
  steps, asked_steps = spec.ppo.get("num_timesteps"), run_spec.ppo.get("num_timesteps")
  note = (f" (a {steps / 1e6:g} M budget)" if steps and asked_steps and steps != asked_steps
          else "")

  def plain(value):  # a recorded tuple reads back from JSON as a list
    return tuple(value) if isinstance(value, list) else value

  row = dataclasses.asdict(ppo_config.ppo_defaults(spec.env))
  trained = {**row, **runs.settings_as_trained(spec.ppo, runs.read_provenance(path))}
  asked = {**row, **run_spec.ppo}
  other = [f"the row's {key}" if plain(trained.get(key)) == row.get(key)
           else f"{key}={plain(trained.get(key))!r}"
           for key in sorted((set(trained) | set(asked)) - {"num_timesteps"}
                             - (set() if returns else set(ppo_config.RETURN_SETTINGS)))
           if plain(trained.get(key)) != plain(asked.get(key))]
  return note + (f" (trained with {', '.join(other)})" if other else "")


def settings_line(sweep_spec: dict) -> str:
  """The PPO settings every arm was asked to train with over the row's (``--config``), or ""."""
  config = sweep_spec.get("config") or {}
  return ("every arm's PPO over the row's: " + ", ".join(f"{k}={v!r}" for k, v in config.items())
          if config else "")


def report(study_name: str, study: Study, directory: str, sweep_spec: dict,
           references: tuple[Reference, ...] | list[Reference] = ()) -> str:
  """Draws ``curves.png`` and writes ``ablation.md`` for the arms of ``sweep_spec`` under
  ``directory``: those evaluated, and those still training (a metrics.csv but no eval.json), drawn
  as unfinished and compared with the others during training, at the last env steps all of them
  reached (also where no arm is evaluated yet: a stopped run's curves are not lost).
  Each of ``references``, other runs (``read_reference``), is drawn over the arms' span of env
  steps and compared with each arm's last evaluation during training; where it has its eval.json,
  also each arm's final evaluation with its own."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  from blx.experiments import plots, sweep
  arms, curves, labels, objectives, styles, devices = {}, {}, {}, {}, {}, {}
  returns = any(metric.startswith("eval/episode_") for metric in study.metrics)
  for name, run_spec in sweep.expand(sweep_spec):
    path = os.path.join(directory, name)
    if not os.path.exists(os.path.join(path, "metrics.csv")):
      continue
    labels[name] = study.label(name, run_spec) + _other_settings(path, run_spec, returns=returns)
    objectives[name] = run_spec.objective
    styles[name] = study.style(run_spec)
    devices[name] = runs.read_provenance(path)
    if any(s.eval_protocol == "final" for s in devices[name]):
      labels[name] += " (curves: the final protocol)"  # 10 episodes, not 4: another estimator
    with open(os.path.join(path, "metrics.csv")) as f:
      curves[name] = with_lgr_goals(with_mode_balance(list(csv.DictReader(f))), devices[name])
    if os.path.exists(os.path.join(path, "eval.json")):
      with open(os.path.join(path, "eval.json")) as f:
        arms[name] = final_lgr_and_balance(json.load(f))
    else:  # still training (or stopped): drawn and compared during training, not in the finals
      labels[name] += " (unfinished)"
  if not curves:
    raise SystemExit(f"{directory}: no arm of {study_name} has run yet (no metrics.csv)")
  metrics = with_other_goals(study.metrics)  # the tables' keys: an LGR on other goals its own
  curved = [logs_curves(r, metrics) for r in references]  # else only a final evaluation
  fig, axes = plt.subplots(1, len(study.metrics), figsize=(5 * len(study.metrics) + 2.4, 3.6),
                           squeeze=False)  # 2.4 inches for the legend beside the panels
  span = max((float(r["env_steps"]) for rows in curves.values() for r in rows), default=0.0)
  for ax, key in zip(axes[0], study.metrics):
    # an LGR on other goals than the paper's is drawn faded beside it, without a legend entry
    faded = False
    for shown_key, alpha in ((key, 1.0), (other_goals(key), 0.35)):
      if shown_key != key and key not in LGR_KEYS:
        continue
      for name, rows in curves.items():
        steps, mean, std = curve(rows, shown_key)
        if not steps:
          continue
        x = [s / 1e6 for s in steps]
        colour, line = styles[name]
        single = len(x) == 1  # an arm of one evaluation so far: a line alone would not show it
        ax.plot(x, mean, line, color=colour, alpha=alpha, marker="o" if single else None,
                markersize=4, label=labels[name] if alpha == 1.0 else None)
        if single:
          ax.errorbar(x, mean, yerr=std, fmt="none", ecolor=colour, alpha=alpha, capsize=3)
        else:
          ax.fill_between(x, [m - s for m, s in zip(mean, std)],
                          [m + s for m, s in zip(mean, std)], color=colour, alpha=0.2 * alpha)
        faded |= alpha < 1.0
        # beside a reference drawn as a point, the arm's own final evaluation is one too, a little
        # to the right: the curves use the protocol of the evaluations during training, which
        # need not be the final one's, so only the two points compare like with like
        values = (arms.get(name) or {}).get("per_seed", {}).get(shown_key)
        if values and not all(curved):
          m, d = paper_tables.mean_std(values)
          ax.errorbar([x[-1] + 0.015 * span / 1e6], [m], yerr=[d], fmt="o", color=colour,
                      alpha=alpha, capsize=3, markersize=5,
                      label=f"{labels[name]}: final evaluation" if alpha == 1.0 else None)
      for reference, style, has_curves in zip(references, REFERENCE_STYLES, curved):
        if not has_curves:  # its final evaluation, a point
          values = (reference.final or {}).get("per_seed", {}).get(shown_key)
          if values:
            m, d = paper_tables.mean_std(values)
            ax.errorbar([reference_steps(reference) / 1e6], [m], yerr=[d], fmt="D", color="0.2",
                        alpha=alpha, capsize=3, markersize=5,
                        label=f"{reference.name}: final evaluation" if alpha == 1.0 else None)
            faded |= alpha < 1.0
          continue
        steps, mean, std = curve(reference.rows, shown_key)
        shown = [(s / 1e6, m, d) for s, m, d in zip(steps, mean, std) if s <= span]
        if shown:
          x, m, d = zip(*shown)
          ax.plot(x, m, style, color="0.2", alpha=alpha,
                  label=reference.name if alpha == 1.0 else None)
          ax.fill_between(x, [a - b for a, b in zip(m, d)], [a + b for a, b in zip(m, d)],
                          color="k", alpha=0.08 * alpha)
          faded |= alpha < 1.0
    ax.set_xlabel("env steps per seed (millions)")
    ax.set_title(LABELS.get(key, key) + ("\n(faded: on blx's goals before session 41, "
                                         "not the paper's)" if faded else ""),
                 fontsize=None if not faded else 9)
    plots.value_axis(ax, key)
    ax.grid(alpha=0.3)
  # Beside the panels rather than over the curves (the saved figure's box takes it in), with every
  # line drawn in any panel: a metric an arm did not log leaves its panel without that arm.
  drawn = {}
  for ax in axes[0]:
    for handle, name in zip(*ax.get_legend_handles_labels()):
      drawn.setdefault(name, handle)
  axes[0][-1].legend(drawn.values(), drawn.keys(), fontsize=7, loc="upper left",
                     bbox_to_anchor=(1.02, 1.0))
  settings = settings_line(sweep_spec)
  title = (f"{study_name}; {study.claim_line}" + (f"; {settings}" if settings else "")
           + " (mean ± std over seeds)")
  fig.suptitle(textwrap.fill(title, 60 * len(study.metrics)), fontsize=9)
  fig.tight_layout()
  fig.savefig(os.path.join(directory, "curves.png"), dpi=120, bbox_inches="tight")
  plt.close(fig)
  labelled = {labels[name]: arm for name, arm in arms.items()}
  table = ("\n".join(compare(labelled, metrics)) if arms
           else "No arm has its final evaluation (eval.json) yet.")
  by_label = {labels[n]: (objectives[n], rows) for n, rows in curves.items()}
  by_arm = {label: rows for label, (_, rows) in by_label.items()}
  if len(arms) < len(curves):
    table += ("\n\nAn arm is unfinished: every arm's evaluation during training at the last env "
              "steps all of them reached:\n\n" + "\n".join(during(by_label, metrics)))
  # references that logged their wall time join the table after the arms (the target stays the
  # first arm's of the objective each faces), named as such: they ran in another process, perhaps
  # on another machine
  timed = {f"{r.name} (reference)": (objectives[facing(r, objectives)[0]], r.rows)
           for r, has_curves in zip(references, curved) if has_curves and _timed(r.rows)}
  with_timed = {**by_label, **timed}
  # the devices column, once any of them recorded where it ran
  ran = {**{labels[n]: devices[n] for n in curves},
         **{f"{r.name} (reference)": list(r.segments) for r in references}}
  ran = {label: ran_on(segments) for label, segments in ran.items()} if any(ran.values()) else None
  if len(curves) + len(timed) > 1 and all(_timed(rows) for rows in by_arm.values()):
    table += ("\n\nWall time to the first arm's last evaluation during training (mean over "
              "seeds), from each run's start, compilation and evaluations included (compare arms "
              "run on one device" + ("; a reference ran in a process of its own, perhaps on "
                                     "another machine" if timed else "") + "):\n\n"
              + "\n".join(time_to(with_timed, metrics, ran)))
  to_paper = time_to_paper(with_timed, sweep_spec["env"], study.metrics, ran)
  if to_paper:
    table += ("\n\nWall time to the paper's value (its mean, `paper_tables.PAPER`), mean over "
              "seeds, from each run's start, on the curve of Braxlines' window where the run "
              "logged it (the paper's numbers are in that window):\n\n" + "\n".join(to_paper))
  finished = [float(r["env_steps"]) for n in arms for r in curves[n] if r.get("env_steps")]
  trained = max(finished) if finished else None
  for reference, has_curves in zip(references, curved):
    faced = facing(reference, objectives)
    whose = ("Each arm's" if len(faced) == len(curves)
             else f"Each {reference.objective} arm's")  # a reference of one objective of several
    if has_curves:
      rows = against({labels[n]: curves[n] for n in faced}, reference.name, reference.rows,
                     metrics)
      table += (f"\n\n{whose} last evaluation during training against {reference.name} at the "
                "same env steps:\n\n" + "\n".join(rows))
    else:
      table += (f"\n\n{reference.name} logged none of the metrics during training (it was "
                "trained without --eval-metrics): it is drawn as its final evaluation, and "
                "compared by final evaluations only.")
    finals = {labels[n]: arm for n, arm in arms.items() if n in faced}
    if reference.final is None or not finals:
      continue
    # a reference may have trained another budget (e.g. the full row of a shorter study): say so
    ended = reference_steps(reference)
    notes = [f"the reference's at {ended / 1e6:.2f} M env steps, the arms' at {trained / 1e6:.2f} M"
             ] if abs(ended - trained) > 0.01 * trained else []
    if {arm.get("objective") for arm in finals.values()} - {reference.final.get("objective")}:
      notes.insert(0, "arms of another objective are tested against their own first arm")
    table += (f"\n\nThe final evaluations (eval.json), first {reference.name}'s"
              + (f" ({'; '.join(notes)})" if notes else "") + ":\n\n"
              + "\n".join(compare({reference.name: reference.final, **finals}, metrics)))
  with open(os.path.join(directory, "ablation.md"), "w") as f:
    settings = f" {settings[0].upper()}{settings[1:]}." if settings else ""
    f.write(f"# {study_name}\n\n{study.claim_line[0].upper()}{study.claim_line[1:]}.\n\n"
            f"{budget_line(study, sweep_spec, trained)}{settings}\n\n{table}\n")
  return table


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("study", nargs="?", choices=sorted(STUDIES))
  parser.add_argument("--list", action="store_true", help="print the studies and their arms")
  parser.add_argument("--env", choices=paper_tables.ENVS, default="ant")
  parser.add_argument("--seeds", type=int, default=10)
  parser.add_argument("--steps", type=int, default=None,
                      help="env steps per seed (default the original's: the env's PPO row x 2; "
                           "x 1 and x 10 for the Composer sweeps); the report names another")
  parser.add_argument("--arm", action="append", default=None, metavar="VALUE",
                      help="train only the arms with this value (JSON, e.g. false or 10.0)")
  parser.add_argument("--objective", action="append", default=None, metavar="NAME",
                      help="train only the arms of this objective (e.g. airl in the gp study)")
  parser.add_argument("--config", default=None, metavar="JSON",
                      help="PPO settings over the row's for every arm, e.g. '{\"num_evals\": 12}'")
  parser.add_argument("--reference", action="append", default=[], metavar="NAME=PATH",
                      help="another run (its directory or metrics.csv, trained with "
                           "--eval-metrics) to draw beside the arms and compare with each arm's "
                           "last evaluation at the same env steps, e.g. a finished row (one "
                           "trained without it: by its eval.json only); up to "
                           f"{len(REFERENCE_STYLES)}, each its own --reference")
  parser.add_argument("--out", default="sweeps/ablations")
  cli.add_eval_protocol_flag(parser)  # the arms always log the metrics during training
  parser.add_argument("--report", action="store_true", help="only draw and tabulate")
  args = parser.parse_args()
  if args.list or args.study is None:
    for name, s in STUDIES.items():
      print(f"{name}: {', '.join(s.objectives)} x {s.option} in {json.dumps(list(s.values))} -- "
            f"{s.claim_line}")
    return
  from blx.experiments import sweep
  study = STUDIES[args.study]
  directory = os.path.join(args.out, f"{args.study}_{args.env}")
  config = None
  if args.config is not None:
    try:  # a bad key or value is named now, not after the first arm has trained
      config = paper_tables.ppo_config(args.config, args.env)
    except ValueError as e:
      parser.error(f"--config: {e}")
  if len(args.reference) > len(REFERENCE_STYLES):
    parser.error(f"--reference: {len(args.reference)} given; at most {len(REFERENCE_STYLES)}")
  references = []
  for given in args.reference:
    name, sep, path = given.partition("=")
    if not (sep and name and path):
      parser.error(f"--reference {given!r}: give NAME=PATH")
    if name in [r.name for r in references]:
      parser.error(f"--reference {name!r}: named twice; give each reference its own name")
    try:
      references.append(read_reference(name, path, study.metrics))
    except ValueError as e:
      parser.error(f"--reference: {e}")
  try:
    sweep_spec = spec(study, args.env, args.seeds, args.steps, config)
  except ValueError as e:  # an env the study is not defined for
    parser.error(f"{args.study} --env {args.env}: {e}")
  arm_names = [study.label(name, run_spec) for name, run_spec in sweep.expand(sweep_spec)]
  for reference in references:
    if reference.name in arm_names:  # the tables would mistake it for the arm of that name
      parser.error(f"--reference {reference.name!r}: an arm's name; give another (the arms: "
                   f"{arm_names})")
  if not args.report:
    only = None
    if args.arm:
      try:
        only = [json.loads(v) for v in args.arm]
      except json.JSONDecodeError as e:
        parser.error(f"--arm: not JSON ({e}); {args.study}'s values are "
                     f"{json.dumps(list(study.values))}")
      bad = [v for v in only if v not in study.values]
      if bad:
        parser.error(f"--arm {bad}: {args.study}'s values are {json.dumps(list(study.values))}")
    objectives = args.objective or list(study.objectives)
    bad = [o for o in objectives if o not in study.objectives]
    if bad:
      parser.error(f"--objective {bad}: {args.study}'s objectives are {list(study.objectives)}")
    select = None if only is None and args.objective is None else (
        lambda name, run_spec: ((only is None or study.value(run_spec) in only)
                                and run_spec.objective in objectives))
    try:
      sweep.run_sweep(sweep_spec, directory, select=select, eval_metrics=True,
                      eval_protocol=args.eval_protocol)
    except KeyboardInterrupt:
      print(f"[ablations] {sweep.INTERRUPTED}", file=sys.stderr)
      raise SystemExit(cli.INTERRUPTED_STATUS)
  print(report(args.study, study, directory, sweep_spec, references))


if __name__ == "__main__":
  cli.run_main(main)  # an interrupted study ends at once, its checkpoints kept
