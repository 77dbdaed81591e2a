"""The paper's Tables 3 and 4 (Ant, HalfCheetah, Humanoid) through the machinery of ``blx sweep``.

    python benchmarks/paper_tables.py [--env ant|halfcheetah|humanoid] [--seeds 10]
                                      [--only gcrl|mimax|dmin] [--objective diayn] [--collect]
                                      [--out sweeps/paper_ENV] [--env-edits JSON] [--config JSON]
                                      [--options JSON] [--steps N] [--eval-metrics]
                                      [--eval-protocol quick|final]
    python benchmarks/paper_tables.py --compare DIR [DIR ...] [--plot PNG]  # every eval.json
    python benchmarks/paper_tables.py --progress DIR [DIR ...] [--plot PNG]  # rows under way
    python benchmarks/paper_tables.py --paired A B [--at STEPS]  # two evaluations, by seed

``--objective`` trains only that algorithm's point (one process per GPU:
``CUDA_VISIBLE_DEVICES=i python benchmarks/paper_tables.py --objective NAME &`` for each), and
``--collect`` then gathers every evaluated point into the tables without training. ``--env-edits``
(dotted paths into the env's desc, e.g. ``'{"global_options.iterations": 4}'``), ``--config`` (PPO
settings over the env's row), ``--options`` (objective options over the row's, e.g.
``'{"target_seed": 3}'``) and ``--steps`` are for ablations: a row trained with any of them is not
the paper's protocol: ``--compare``, ``--progress`` and ``--plot`` name a run's PPO settings that
are not the original's (``blx.training.config.off_row``, from its provenance's record of every
setting it trained with, else its ``config.json``: ``trained_off_row``), but for how its return
episodes act (``eval_actions``), which the paper's metrics do not depend on; and its env edits and
objective options that are not the row's (``desc_off_row``: "env global_options.iterations 4 (the
original's: 1)"), and the observers a run's config held where its env's have changed since ("older
env components.agent1.observers ...": the humanoid's rows before 2026-12-06). ``--compare`` and
``--paired`` also name a row trained for other env steps per seed than the paper's (``--steps``;
``length_line``): a length is not a setting of how it learns, but a row at twice the paper's steps
is not the paper's row either.
Below its verdicts ``--compare`` splits each MI-max row's MI gap into its H(s) and H(s|z) parts
(``mi_parts``). ``--compare DIR ... --plot PNG`` also draws the rows' final evaluations beside the
paper's values (``draw_compare``), ``--progress DIR ... --plot PNG`` their curves
(``draw_progress``).
``--paired A B`` compares two final evaluations of one row (``eval.json`` files or run directories)
seed by seed, e.g. an option's arm against the paper's row trained on the same seed numbers; with
``--at STEPS``, the two runs' evaluations during training at STEPS env steps per seed (their
``metrics.csv``, logged with ``--eval-metrics``: ``logged_at``), e.g. an arm stopped early against
the row at the same steps.
``--first-seed N`` trains seeds N .. N + seeds - 1, so that one row's seeds can be split over
processes or device calls; ``--compare DIR1 DIR2`` then merges the ``eval.json`` files found at the
same path under each directory into one row (their seeds must not overlap; files at one path that
are not one row's parts are refused, as is a DIR without an ``eval.json``, each named); where one
table holds several evaluations of one row (a rerun beside the first run), each of their rows names
its file. ``--eval-metrics`` also logs the paper's metrics at every evaluation during training (e.g.
D-min's mode shares), at the cost of a quick evaluation each time (4 episodes; ``--eval-protocol
final``: the final evaluation's 10, ``runs.EVAL_PROTOCOLS``).

MI-max: gcrl, diayn, cdiayn, diayn_full on the env's "vel" indices (Ant and Humanoid: xy velocity;
HalfCheetah: x velocity), obs_scale 5, spectral norm on; D-min: gail, gail2, airl, mle to the
bimodal target on the same indices (Ant, Humanoid: modes (+-4, 0), std 0.8; HalfCheetah: +-2.67,
std 0.53), obs_scale 8, spectral norm off. PPO: the env's row with twice its steps (Ant 60 M,
HalfCheetah 200 M, Humanoid 100 M per seed), seeds vmapped in one program per algorithm. Writes
summary.md / .csv / .tex per sweep and prints them beside the paper's values, then a verdict per
row and metric: Welch's t-test against the paper's mean and std over its 10 seeds, and whether blx
reaches the paper's mean - 1 std (in the direction where larger is better).
"""

from __future__ import annotations

import argparse
import collections
import csv
import glob
import json
import math
import os
import sys
import textwrap

from blx.experiments import cli, runs, sweep
from blx.training.config import off_row, ppo_defaults

# The paper's rows (Tables 3 and 4; 10 seeds): env -> algorithm -> metric -> (mean, std). -LGR and
# -energy distance as printed; larger is better for every one.
PAPER = {
    "ant": {
        "diayn": {"eval/mi": (1.115, 0.268), "eval/entropy": (5.558, 0.286),
                  "-eval/lgr": (-2.260, 0.539)},
        "diayn_full": {"eval/mi": (0.034, 0.006), "eval/entropy": (5.044, 0.039),
                       "-eval/lgr": (-3.010, 0.010)},
        "gcrl": {"eval/mi": (1.218, 0.192), "eval/entropy": (6.066, 0.051),
                 "-eval/lgr": (-2.074, 0.232)},
        "cdiayn": {"eval/mi": (0.750, 0.185), "eval/entropy": (5.253, 0.270),
                   "-eval/lgr": (-2.885, 0.291)},
        "airl": {"-eval/energy_distance": (-2.588, 1.194)},
        "gail": {"-eval/energy_distance": (-0.802, 0.460)},
        "gail2": {"-eval/energy_distance": (-2.898, 0.946)},
        "mle": {"-eval/energy_distance": (-1.829, 0.573)},
    },
    "halfcheetah": {
        "diayn": {"eval/mi": (1.815, 0.201), "eval/entropy": (5.164, 0.455),
                  "-eval/lgr": (-0.492, 0.154)},
        "diayn_full": {"eval/mi": (0.490, 0.156), "eval/entropy": (5.519, 0.178),
                       "-eval/lgr": (-1.397, 0.287)},
        "gcrl": {"eval/mi": (1.626, 0.157), "eval/entropy": (5.307, 0.173),
                 "-eval/lgr": (-0.293, 0.356)},
        "cdiayn": {"eval/mi": (1.551, 0.098), "eval/entropy": (5.104, 0.353),
                   "-eval/lgr": (-0.741, 0.365)},
        "airl": {"-eval/energy_distance": (-1.448, 0.843)},
        "gail": {"-eval/energy_distance": (-0.516, 0.640)},
        "gail2": {"-eval/energy_distance": (-2.488, 0.355)},
        "mle": {"-eval/energy_distance": (-2.614, 0.415)},
    },
    "humanoid": {
        "diayn": {"eval/mi": (0.927, 0.128), "eval/entropy": (6.074, 0.088),
                  "-eval/lgr": (-2.313, 0.266)},
        "diayn_full": {"eval/mi": (0.071, 0.007), "eval/entropy": (5.676, 0.081),
                       "-eval/lgr": (-3.051, 0.028)},
        "gcrl": {"eval/mi": (0.769, 0.146), "eval/entropy": (6.058, 0.063),
                 "-eval/lgr": (-2.755, 0.115)},
        "cdiayn": {"eval/mi": (0.297, 0.147), "eval/entropy": (5.677, 0.060),
                   "-eval/lgr": (-2.738, 0.112)},
        "airl": {"-eval/energy_distance": (-1.122, 0.210)},
        "gail": {"-eval/energy_distance": (-1.790, 0.413)},
        "gail2": {"-eval/energy_distance": (-1.471, 0.528)},
        "mle": {"-eval/energy_distance": (-2.037, 0.973)},
    },
}
ENVS = tuple(PAPER)
PAPER_SEEDS = 10
# The paper's MI-max rows whose evaluator draws latents from a continuous prior rather than reading
# fixed skills (``metrics.draws_latents`` of their presets; a test checks the two agree).
DRAWN_LATENTS = frozenset({"cdiayn", "gcrl"})


def welch(values: list[float], mean: float, std: float, n: int = PAPER_SEEDS):
  """Welch's t-test of ``values`` against a sample of ``n`` with ``mean`` and (population) ``std``:
  ``(t, degrees of freedom, two-sided p)``. Both stds are made sample stds (ddof 1) first. One
  value has no sample std, so there is no test: ``ValueError``."""
  from scipy import stats
  m = len(values)
  if m < 2:
    raise ValueError(f"welch: {m} value(s); the test needs at least 2 seeds")
  mu = sum(values) / m
  var = sum((v - mu) ** 2 for v in values) / (m - 1)
  var_p = std**2 * n / (n - 1)
  se2 = var / m + var_p / n
  t = (mu - mean) / math.sqrt(se2)
  dof = se2**2 / ((var / m) ** 2 / (m - 1) + (var_p / n) ** 2 / (n - 1))
  return t, dof, 2 * stats.t.sf(abs(t), dof)


def mean_std(values: list[float]) -> tuple[float, float]:
  """Mean and population std, as the paper reports over its seeds."""
  mu = sum(values) / len(values)
  return mu, math.sqrt(sum((v - mu) ** 2 for v in values) / len(values))


# How ``verdicts`` labels an LGR evaluated on other goals than the paper's: those blx's evaluators
# drew before session 41 (``metrics.lgr_goals(draw="partitionable")``), where the evaluation does
# not record ``lgr_goals`` "braxlines".
OTHER_GOALS = " (not the paper's goals: blx's before session 41)"


BLX_WINDOW, BRAXLINES_WINDOW = "blx's window", "Braxlines' window"


def scored(eval_json: dict) -> list[tuple[str, str, str, float, float, list[float]]]:
  """The metrics of the paper's row that ``eval_json`` holds per seed, in the table's order: each in
  blx's fixed window, then (where the run logged it) in the window Braxlines' rollout scores
  (``metrics.braxlines_window``), against the same paper value. Each is ``(the paper's key, e.g.
  "-eval/lgr"; the evaluation's key, e.g. "eval/lgr_braxlines"; the window; the paper's mean; its
  std; blx's per-seed values signed as the paper's key, so that larger is better)``."""
  name, env = eval_json["objective"], eval_json.get("env", "ant")
  out = []
  for window, suffix in ((BLX_WINDOW, ""), (BRAXLINES_WINDOW, "_braxlines")):
    for key, (mean, std) in PAPER.get(env, {}).get(name, {}).items():
      sign = -1.0 if key.startswith("-") else 1.0
      metric = key.lstrip("-") + suffix
      values = [sign * v for v in eval_json["per_seed"].get(metric, [])]
      if values:
        out.append((key, metric, window, mean, std, values))
  return out


def papers_goals(eval_json: dict) -> bool:
  """Whether the evaluation's LGR was taken on the paper's goals (its ``evaluated_on`` says so)."""
  return (eval_json.get("evaluated_on") or {}).get("lgr_goals") == "braxlines"


def tested(values: list[float], mean: float, std: float):
  """blx's ``values`` (larger better) against the paper's row ``mean`` ± ``std``: ``(blx's mean,
  its std, whether it reaches the paper's mean - std, Welch's (t, p) or None for one seed)``."""
  mu, sd = mean_std(values)
  test = welch(values, mean, std)[::2] if len(values) > 1 else None
  return mu, sd, mu >= mean - std, test


def verdicts(eval_json: dict, source: str | None = None) -> list[str]:
  """Markdown rows: metric, blx mean ± std (n), paper, Welch t and p, and whether blx reaches the
  paper's mean - std, for each of ``scored``'s metrics. An LGR evaluated on other goals than the
  paper's (``evaluated_on``'s ``lgr_goals`` not "braxlines") says so (``OTHER_GOALS``).
  ``source``, where given, names the evaluation's file beside its algorithm (``compare`` does where
  one table holds several evaluations of one row)."""
  name, env = eval_json["objective"], eval_json.get("env", "ant")
  algorithm = name if source is None else f"{name} ({source})"
  lines = []
  for key, metric, window, mean, std, values in scored(eval_json):
    mu, sd, meets, welch_t_p = tested(values, mean, std)
    ok = "yes" if meets else "**no**"
    test = f"{welch_t_p[0]:+.2f} | {welch_t_p[1]:.3f}" if welch_t_p else "n/a (1 seed) | n/a"
    if window == BRAXLINES_WINDOW:
      key += f" ({window})"
    if metric == "eval/lgr" and not papers_goals(eval_json):
      key += OTHER_GOALS
    lines.append(f"| {env} | {algorithm} | {key} | {mu:.3f} ± {sd:.3f} ({len(values)}) "
                 f"| {mean:.3f} ± {std:.3f} | {test} | {ok} |")
  return lines


def merge(evals: list[dict]) -> dict:
  """One evaluation of a row whose seeds ran in several programs: per-seed values concatenated in
  seed order. The parts must be of one env and algorithm and share no seed."""
  first = evals[0]
  for other in evals[1:]:
    if (other["objective"], other.get("env")) != (first["objective"], first.get("env")):
      raise ValueError(f"merge: {other['objective']} on {other.get('env')} is not the row of "
                       f"{first['objective']} on {first.get('env')}")
  seeds = [s for e in evals for s in e["seeds"]]
  if len(set(seeds)) != len(seeds):
    raise ValueError(f"merge: seeds {sorted(seeds)} overlap; each part must train other seeds")
  keys = set.intersection(*(set(e["per_seed"]) for e in evals))
  order = sorted(range(len(seeds)), key=seeds.__getitem__)
  per_seed = {k: [v for e in evals for v in e["per_seed"][k]] for k in keys}
  return dict(first, seeds=sorted(seeds),
              per_seed={k: [v[i] for i in order] for k, v in per_seed.items()})


VERDICT_HEADER = ["| env | algorithm | metric | blx (seeds) | paper (10) | Welch t | p "
                  "| >= paper mean - std |",
                  "| --- | --- | --- | ---: | ---: | ---: | ---: | --- |"]


def trained_off_row(name: str, config: dict) -> dict[str, tuple]:
  """``off_row`` of the run ``name`` (as ``logged`` names it): every PPO setting it trained with
  that is not its row's, from its provenance's record where it has one, else from its config.json
  (``runs.settings_as_trained``), so that a setting taken from a default that moved since is
  named too; but for those of the return episodes alone (``eval_actions``), which the paper's
  metrics, the tables' only ones, do not depend on. Then its env edits and objective options that
  are not the row's (``desc_off_row``)."""
  ppo = off_row(config["env"], runs.settings_as_trained(config.get("ppo"), run_segments(name)),
                returns=False)
  return {**ppo, **desc_off_row(config)}


_UNSET = "unset"


def desc_off_row(config: dict) -> dict[str, tuple]:
  """The env edits (``--env-edits``) and objective options (``--options``) of a run's
  ``config.json`` that are not its row's: ``{"env PATH": (the run's, the env's), "objective KEY":
  (the run's, the row's)}``. The env's value is that of its registered desc, or the composer's
  default for a global option the desc leaves out, or the component's default observers where the
  desc names none (``_observers_of``); the row's option is the one ``specs`` sets, else the
  preset's default. "unset" stands for a value neither has. An edit or option that restates the
  original's is not named; a run of an objective no row trains names none. Then the observers its
  config's desc held where its env's have changed since (``_older_observers``)."""
  from blx import envs, objectives
  from blx.envs.composer import GLOBAL_OPTIONS
  same = lambda a, b: json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
  out = {}
  edits = (config.get("env_params") or {}).get("edits") or {}
  if edits:
    desc = envs.get_desc(config["env"])
    for path, value in edits.items():
      node, keys = desc, path.split(".")
      for key in keys:
        node = node.get(key, _UNSET) if isinstance(node, dict) else _UNSET
      if node == _UNSET and keys[0] == "global_options" and len(keys) == 2:
        node = GLOBAL_OPTIONS.get(keys[1], _UNSET)
      if node == _UNSET and len(keys) == 3 and keys[0] == "components" and keys[2] == "observers":
        node = _observers_of(desc.get("components", {}).get(keys[1]))
      if not same(value, node):
        out[f"env {path}"] = (value, node)
  out.update(_older_observers(config, edits))
  row = next((spec["options"] for spec in specs(1, env=config["env"]).values()
              if config["objective"] in spec["objective"]), None)
  if row is not None:
    original = {**objectives.option_defaults(config["objective"]), **row}
    given = config.get("objective_options") or {}
    for key in sorted(given):
      if not same(given[key], original.get(key, _UNSET)):
        out[f"objective {key}"] = (given[key], original.get(key, _UNSET))
  return out


OLDER = "older env"  # desc_off_row's key of a setting blx's env had when the run was configured


def _older_observers(config: dict, edits: dict) -> dict[str, tuple]:
  """The observers a run's components had by its ``config.json``'s desc, where they are not its
  registered env's now and no edit of the run names them: ``{"older env components.NAME.observers":
  (the run's, the env's now)}``. A registered env's observation can grow after runs were
  configured (the humanoid's did, by Brax's contacts and motors' part, on 2026-12-06); such a run
  is rebuilt from its desc as it trained, and is not the row as blx builds it now."""
  from blx import envs
  stored = config.get("desc")
  if not isinstance(stored, dict) or config.get("env") not in envs.list_envs():
    return {}
  out = {}
  for name, component in (envs.get_desc(config["env"]).get("components") or {}).items():
    path = f"components.{name}.observers"
    trained = _observers_of((stored.get("components") or {}).get(name))
    now = _observers_of(component)
    if path not in edits and trained != _UNSET and runs.as_json(trained) != runs.as_json(now):
      out[f"{OLDER} {path}"] = (runs.as_json(trained), runs.as_json(now))
  return out


def _observers_of(component: dict | None) -> list | str:
  """The observers of a component of an env's desc: those it names, else its registered
  component's defaults (``blx.envs.components.make_component``); "unset" where the desc has no
  such component."""
  from blx.envs import components
  if isinstance(component, dict) and "observers" in component:
    return runs.as_json(list(component["observers"]))
  if not isinstance(component, dict) or "component" not in component:
    return _UNSET
  spec = components.make_component(component["component"], component.get("component_params"))
  return runs.as_json(list(spec.observers))


def options_line(name: str, changed: dict[str, tuple]) -> list[str]:
  """A line naming ``name``'s settings that are not the original's (``changed``, as
  ``trained_off_row`` gives them), or none."""
  named = [f"{key} {value} (the original's: {default})"
           for key, (value, default) in changed.items()]
  older = all(key.startswith(OLDER) for key in changed)
  verdict = ("Trained on blx's older env, not the paper's row as blx builds it now." if older else
             "An option's result, not the paper's row.")
  return [f"{name}: settings not the original's: {'; '.join(named)}. {verdict}"] if named else []


def length_line(name: str, config: dict) -> list[str]:
  """A line where the run ``name`` of a paper's row (its ``config``) was asked for other env steps
  per seed than the paper's (``paper_steps``), or none. Its length is bookkeeping to ``off_row``
  (a run's settings, how it learns); to a verdict it is not: the paper's MI after twice its steps
  is not the paper's row. The length asked for, as its provenance recorded it (``Segment.ppo``),
  else its config.json; none where neither names it."""
  env, objective = config.get("env"), config.get("objective")
  if objective not in PAPER.get(env, {}):
    return []
  steps = runs.settings_as_trained(config.get("ppo"), run_segments(name)).get("num_timesteps")
  paper = paper_steps(env)
  if steps is None or int(steps) == paper:
    return []
  return [f"{name}: trained for {int(steps):,} env steps per seed, the paper's row for "
          f"{paper:,}: {'longer' if steps > paper else 'shorter'} than the paper's protocol, not "
          "its row."]


def eval_settings(eval_path: str) -> tuple[dict[str, tuple], list[str]]:
  """The settings of the run of the ``eval.json`` at ``eval_path`` that are not the original's
  (``trained_off_row``), from the ``config.json`` beside it, and its ``options_line`` and
  ``length_line``; or ``{}`` and a line saying its config could not be read; ``({}, [])`` where it
  has none. The same for a ``metrics.csv`` at ``eval_path``."""
  prefix = eval_path[:-len("metrics.csv" if eval_path.endswith("metrics.csv") else "eval.json")]
  if not os.path.exists(prefix + "config.json"):
    return {}, []
  config = read_config(prefix)
  if not isinstance(config, dict):
    return {}, [f"{config}: its settings were not checked against the original's"]
  name = prefix.rstrip("_/" + os.sep)
  changed = trained_off_row(name, config)
  return changed, options_line(name, changed) + length_line(name, config)


def eval_options(eval_path: str) -> list[str]:
  """``eval_settings``' lines alone: the run's ``options_line``, or why its config was not read."""
  return eval_settings(eval_path)[1]


def eval_files(directory: str) -> list[str]:
  """Every evaluation under ``directory``, in path order: a run's ``eval.json`` and a committed
  row's ``NAME_eval.json``; ``[]`` where there is none (or no such directory)."""
  return sorted(glob.glob(os.path.join(directory, "**", "*eval.json"), recursive=True))


def compared(*directories: str) -> tuple[list[tuple[str | None, dict, dict]], list[str]]:
  """Every ``eval.json`` under the directories, as ``compare`` tables them: ``([(source, the
  evaluation, its settings not the original's)], notes)``, one evaluation per path (files at the
  same path under several directories merged: ``merge``), in path order; ``source`` names its file
  where several evaluations of one env's row are among them, else None; the settings as
  ``eval_settings`` gives them (``{}``: the original's); ``notes``, a line per run with such
  settings (``options_line``) or another length (``length_line``). Raises ValueError as
  ``compare`` says."""
  parts: dict[str, list[dict]] = {}
  found: dict[str, list[str]] = {}  # where each path's parts came from
  notes: dict[str, list[str]] = {}
  settings: dict[str, dict] = {}
  for directory in directories:
    paths = eval_files(directory)
    if not paths:
      raise ValueError(f"no eval.json under {directory}" + (
          "" if os.path.isdir(directory) else " (no such directory)") + ": give the --out of "
          "paper_tables.py, a run directory, or a folder of committed rows (NAME_eval.json)")
    for path in paths:
      rel = os.path.relpath(path, directory)
      with open(path) as f:
        parts.setdefault(rel, []).append(json.load(f))
      found.setdefault(rel, []).append(directory)
      changed, lines = eval_settings(path)
      seen = notes.setdefault(rel, [])
      seen += [line for line in lines if line not in seen]
      settings.setdefault(rel, {}).update(changed)
  merged = {}
  for rel in sorted(parts):
    try:
      merged[rel] = merge(parts[rel])
    except ValueError as e:
      raise ValueError(
          f"{rel} under {' and '.join(found[rel])}: {e}. Files at one path under several "
          "directories are parts of one row (its seeds trained in several programs, "
          "--first-seed); compare other rows, such as another env's, with a --compare of their "
          "own") from None
  per_row = collections.Counter((m.get("env", "ant"), m["objective"]) for m in merged.values())
  rows = [(rel if per_row[m.get("env", "ant"), m["objective"]] > 1 else None, m, settings[rel])
          for rel, m in merged.items()]
  return rows, [line for rel in sorted(notes) for line in notes[rel]]


def mi_parts(eval_json: dict) -> tuple[float, float, float, float, float, float] | None:
  """Where an MI-max row's MI departs from the paper's, split by MI = H(s) - H(s|z): ``(blx's MI,
  the paper's, blx's H(s), the paper's, blx's mean_z H(s|z), the paper's)``, each blx value a mean
  over seeds (blx's window). The paper reports no H(s|z); since each seed's MI is its H(s) less its
  H(s|z), the paper's mean H(s|z) is its mean H(s) less its mean MI, exactly. So the MI's shortfall
  is the part of H(s) (the states the skills cover together) less the part of H(s|z) (how widely
  each skill's states spread). None for a row without the three metrics (D-min; an evaluation
  from before blx recorded H(s|z))."""
  row = PAPER.get(eval_json.get("env", "ant"), {}).get(eval_json["objective"], {})
  per_seed = eval_json["per_seed"]
  keys = ("eval/mi", "eval/entropy", "eval/conditional_entropy")
  if not {"eval/mi", "eval/entropy"} <= set(row) or not all(per_seed.get(k) for k in keys):
    return None
  mi, h, hz = (mean_std(per_seed[k])[0] for k in keys)
  paper_mi, paper_h = row["eval/mi"][0], row["eval/entropy"][0]
  return mi, paper_mi, h, paper_h, hz, paper_h - paper_mi


MI_PARTS_HEADER = [
    "MI = H(s) - H(s|z): where each MI-max row's MI departs from the paper's (means over seeds, "
    "blx's window; the paper's H(s|z) is its H(s) less its MI). H(s): how much the skills cover "
    "together; H(s|z): how widely each skill's states spread.", "",
    "| env | algorithm | MI, blx - paper | H(s), blx - paper | H(s\\|z), blx - paper |",
    "| --- | --- | ---: | ---: | ---: |"]


def compare(*directories: str) -> str:
  """The verdict table for every ``eval.json`` under the directories; files at the same path under
  several directories are parts of one row (``merge``). Below it, for the MI-max rows, where their
  MI departs from the paper's, split into H(s) and H(s|z) (``mi_parts``); then each row's settings
  that are not the original's (PPO's, env edits, objective options: ``options_line``, from the
  ``config.json`` beside its ``eval.json``) and its env steps per seed where they are not the
  paper's (``length_line``). Where the table holds several evaluations of one env's row (a rerun
  beside the first run, say), each of their rows names its file. Raises ValueError for a directory
  that holds no ``eval.json``, and for files at one path that are not parts of one row, naming
  them."""
  evaluations, notes = compared(*directories)
  rows, parts = list(VERDICT_HEADER), []
  for source, evaluation, _ in evaluations:
    algorithm = evaluation["objective"] + (f" ({source})" if source else "")
    rows += verdicts(evaluation, source=source)
    split = mi_parts(evaluation)
    if split:
      mi, paper_mi, h, paper_h, hz, paper_hz = split
      parts.append(f"| {evaluation.get('env', 'ant')} | {algorithm} | {mi:.3f} - {paper_mi:.3f} "
                   f"= {mi - paper_mi:+.3f} | {h:.3f} - {paper_h:.3f} = {h - paper_h:+.3f} | "
                   f"{hz:.3f} - {paper_hz:.3f} = {hz - paper_hz:+.3f} |")
  if parts:
    rows += [""] + MI_PARTS_HEADER + parts
  return "\n".join(rows + ([""] + notes if notes else []))


# The order of ``draw_compare``'s panels: the paper's metrics, MI-max's then D-min's.
PANEL_ORDER = ("eval/mi", "eval/entropy", "eval/lgr", "eval/energy_distance")


def _verdict(values: list[float], mean: float, std: float, alpha: float = 0.05) -> str:
  """"meets" or "short" (blx's mean against the paper's mean - std, larger better), then by Welch's
  test against the paper's row at level ``alpha`` whether blx is better, level or worse, with p."""
  _, _, meets, welch_t_p = tested(values, mean, std)
  word = "meets" if meets else "short"
  if welch_t_p is None:
    return f"{word} (1 seed, no test)"
  t, p = welch_t_p
  relation = "level with" if p >= alpha else "better than" if t > 0 else "worse than"
  return f"{word}; {relation} the paper ({'p < 0.001' if p < 0.001 else f'p {p:.3f}'})"


def draw_compare(path: str, *directories: str) -> dict[str, list[str]]:
  """``path``, a PNG: every row that ``compare`` tables, its final evaluation beside the paper's
  value, a panel per metric of the paper's tables (MI, H(s), LGR, energy distance; each in its own
  units, LGR and energy distance as distances, lower better): the paper's mean ± std, blx's mean ±
  std over seeds and each seed, in blx's window and, where the run logged it, in Braxlines'. Each
  row's label names its algorithm (and file, as ``compare`` does), its settings that are not the
  original's (an option's result, ``eval_settings``), an LGR on other goals than the paper's, and
  the verdict in each window, as ``verdicts`` has it. Returns each panel's labels,
  top to bottom, by metric. Raises ValueError where no evaluation holds a metric of the paper's
  row."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  import ablations  # its labels; it imports this module, so not at the top
  evaluations, _ = compared(*directories)
  envs = sorted({e.get("env", "ant") for _, e, _ in evaluations})
  panels: dict[str, list[tuple[str, float, float, dict[str, list[float]]]]] = {}
  for source, evaluation, changed in evaluations:
    by_metric: dict[str, dict] = {}
    for key, metric, window, mean, std, values in scored(evaluation):
      base = key.lstrip("-")
      sign = -1.0 if key.startswith("-") else 1.0
      entry = by_metric.setdefault(base, {"mean": sign * mean, "std": std, "windows": {},
                                          "verdicts": []})
      entry["windows"][window] = [sign * v for v in values]  # in the metric's own units
      entry["verdicts"].append((window, _verdict(values, mean, std)))
    for base, entry in by_metric.items():
      name = evaluation["objective"]
      if len(envs) > 1:
        name = f"{evaluation.get('env', 'ant')} {name}"
      lines = [name + (f" ({source})" if source else "")]
      if changed:  # an option's result, not the paper's row
        lines.append("option " + ", ".join(f"{k} {v}" for k, (v, _) in changed.items()) +
                     ", not the original's")
      if base == "eval/lgr" and not papers_goals(evaluation):
        lines.append("on blx's old goals, not the paper's")
      if len(entry["verdicts"]) == 1:
        lines.append(entry["verdicts"][0][1])
      else:
        lines += [f"{window}: {verdict}" for window, verdict in entry["verdicts"]]
      panels.setdefault(base, []).append(("\n".join(lines), entry["mean"], entry["std"],
                                          entry["windows"]))
  order = [m for m in PANEL_ORDER if m in panels]
  if not order:
    raise ValueError(f"nothing to draw under {', '.join(directories)}: no eval.json there holds "
                     "a metric of a row of the paper's tables")
  columns = 1 if len(order) == 1 else 2
  grid = [order[i:i + columns] for i in range(0, len(order), columns)]
  heights = [max(len(panels[m]) for m in line) for line in grid]
  fig, axes = plt.subplots(len(grid), columns, figsize=(7.5 * columns, 0.9 * sum(heights) + 1.6),
                           squeeze=False, layout="constrained",
                           gridspec_kw={"height_ratios": heights})
  styles = {BLX_WINDOW: dict(fmt="o", color="C0", offset=0.0),
            BRAXLINES_WINDOW: dict(fmt="D", color="C2", offset=-0.25, mfc="white")}
  drawn, legend = {}, {}
  for line, row_axes in zip(grid, axes):
    for metric, ax in zip(line, row_axes):
      entries = panels[metric]
      for i, (label, mean, std, windows) in enumerate(entries):
        y = -i
        ax.errorbar([mean], [y + 0.25], xerr=[std], fmt="s", color="C3", mfc="white", capsize=3,
                    label="the paper (mean ± std, 10 seeds)" if i == 0 else None)
        for window, values in windows.items():
          style = styles[window]
          mu, sd = mean_std(values)
          yy = y + style["offset"]
          ax.plot(values, [yy - 0.1] * len(values), ".", color=style["color"], alpha=0.45,
                  ms=5, label="blx, each seed (in its window's colour)")
          ax.errorbar([mu], [yy], xerr=[sd], fmt=style["fmt"], color=style["color"], capsize=3,
                      mfc=style.get("mfc", style["color"]),
                      label=f"blx, {window} (mean ± std over seeds)")
      ax.set_yticks([-i for i in range(len(entries))], [e[0] for e in entries], fontsize=7.5)
      ax.set_ylim(-len(entries) + 0.4, 0.7)
      ax.set_xlabel(ablations.LABELS.get(metric, metric))
      ax.grid(axis="x", alpha=0.3)
      drawn[metric] = [e[0] for e in entries]
      handles, labels = ax.get_legend_handles_labels()
      for label, handle in zip(labels, handles):
        legend.setdefault(label, handle)
    for ax in row_axes[len(line):]:
      ax.axis("off")
  fig.legend(legend.values(), legend.keys(), loc="outside lower center", ncols=len(legend),
             fontsize=8)
  fig.suptitle(textwrap.fill(
      f"{', '.join(envs)}: blx's final evaluations against the paper's Tables 3 and 4 "
      "(\"meets\": blx's mean at least the paper's mean - std, in the better direction; p: "
      "Welch's t-test against the paper's row)", 120), fontsize=10)
  fig.savefig(path, dpi=110)
  plt.close(fig)
  return drawn


def logged(*directories: str) -> list[tuple[str, dict | str, list[dict], str | None]]:
  """Every run under the directories that logged metrics during training: ``(name, config,
  metrics.csv rows, final)``, in name order; ``final``, the path of its ``eval.json`` where it
  finished, else None. A run directory's ``metrics.csv`` goes with its ``config.json`` and
  ``eval.json``; a committed row's ``NAME_metrics.csv`` (as under ``benchmarks/paper/``) with
  ``NAME_config.json`` and ``NAME_eval.json``. ``config`` is the run's config (its ``env`` and
  ``objective``), or a string saying why it cannot be read. A path that is itself a
  ``metrics.csv`` or ``NAME_metrics.csv`` file stands for that one run (one committed row of a
  directory that holds several)."""
  found: set[str] = set()
  for directory in directories:
    if os.path.isfile(directory):
      found.add(read_metrics(directory))
    else:
      found.update(glob.glob(os.path.join(directory, "**", "*metrics.csv"), recursive=True))
  paths = sorted(found)
  if not paths:
    raise ValueError(f"no metrics.csv under {', '.join(directories)}: give run directories, or "
                     "the --out of paper_tables.py")
  return [logged_run(path) for path in paths]


def read_config(prefix: str) -> dict | str:
  """The run config ``PREFIXconfig.json`` (``prefix``: a run directory with its separator, or a
  committed row's ``DIR/NAME_``), or a string saying why it cannot be read."""
  try:
    with open(prefix + "config.json") as f:
      read = json.load(f)
  except (OSError, ValueError) as e:
    return f"{prefix}config.json is unreadable ({e})"
  return (read if isinstance(read, dict) and {"env", "objective"} <= set(read) else
          f"{prefix}config.json is not a blx run config (it names no env and objective)")


def logged_run(path: str) -> tuple[str, dict | str, list[dict], str | None]:
  """One run's ``(name, config, metrics.csv rows, final)`` as ``logged`` gives them, from the
  path of its ``metrics.csv`` or ``NAME_metrics.csv``."""
  prefix = path[:-len("metrics.csv")]
  name = prefix.rstrip("_/" + os.sep) or path
  config: dict | str = f"no {os.path.basename(prefix)}config.json beside its metrics.csv"
  if os.path.exists(prefix + "config.json"):
    config = read_config(prefix)
  with open(path) as f:
    rows = list(csv.DictReader(f))
  final = prefix + "eval.json"
  return name, config, rows, final if os.path.exists(final) else None


def _paper_curves(rows: list[dict], env: str, objective: str,
                  blx_window: frozenset = frozenset()):
  """Per metric of the paper's row of ``objective`` on ``env``: ``(key, paper mean, paper std,
  window, (env steps, mean, std), other)``, the curve in Braxlines' window (where the paper's
  numbers were taken) where the run logged it and ``key`` is not in ``blx_window``, else in blx's;
  ``other``, an LGR's curve on other goals than the paper's (``rows`` as
  ``ablations.with_lgr_goals`` gives them), else empty."""
  import ablations  # its curves; it imports this module, so not at the top
  out = []
  for key, (mean, std) in PAPER.get(env, {}).get(objective, {}).items():
    sign, key = (-1.0, key[1:]) if key.startswith("-") else (1.0, key)
    window, curve = (("blx's", ablations.curve(rows, key)) if key in blx_window
                     else ablations.paper_window_curve(rows, key))
    other = (ablations.curve(rows, ablations.other_goals(key)) if key in ablations.LGR_KEYS
             else ([], [], []))
    out.append((key, sign * mean, std, f"{window} window", curve, other))
  return out


def _budget(rows: list[dict]) -> float | None:
  """A run's env steps per seed to train, from its metrics.csv rows (``total_steps``); None for a
  run from before blx logged it."""
  budgets = [float(r["total_steps"]) for r in rows if r.get("total_steps")]
  return max(budgets) if budgets else None


ONE_MODE = 0.1  # a mode balance below it: the least visited mode has under 5 % of the states


def run_segments(name: str) -> list[runs.Segment]:
  """The provenance segments of the run ``name`` (as ``logged`` names it): a committed row's
  ``NAME_provenance.json``, or ``NAME/provenance.json``; ``[]`` where it has none."""
  for directory, filename in ((os.path.dirname(name),
                               f"{os.path.basename(name)}_{runs.PROVENANCE}"),
                              (name, runs.PROVENANCE)):
    if os.path.exists(os.path.join(directory, filename)):
      return runs.read_provenance(directory, filename)
  return []


def progress(*directories: str) -> str:
  """Where rows under training stand: for every run under the directories (``logged``) that logged
  the paper's metrics during training (``--eval-metrics``), the verdicts of its last evaluation
  that every seed reached, against the paper (as ``verdicts``), and the env steps and wall time at
  which its mean over seeds first reached the paper's mean (``ablations.time_to_paper``); for a
  D-min run, the mode balance there and how many seeds are on one mode (``ONE_MODE``). A run
  without a paper row, without those metrics, or without its config is named and passed over. A
  row's parts trained in several programs (``--first-seed``) are each their own run here."""
  import ablations  # its curves; it imports this module, so not at the top
  out = []
  for name, config, rows, final in logged(*directories):
    if isinstance(config, str):
      out.append(f"{name}: passed over: {config}\n")
      continue
    env, objective = config["env"], config["objective"]
    paper = PAPER.get(env, {}).get(objective, {})
    if not paper:
      out.append(f"{name}: {objective} on {env} has no row in the paper's tables\n")
      continue
    keys = [key.lstrip("-") for key in paper]
    keys += [f"{key}_braxlines" for key in keys]
    values = {key: ablations.by_step(rows, key) for key in keys}
    steps = ablations.complete_steps(values[keys[0]])
    if not steps:
      out.append(f"{name}: no evaluation with the paper's metrics in its metrics.csv (train "
                 "with --eval-metrics)\n")
      continue
    last = steps[-1]
    seeds = sorted(values[keys[0]][last])
    per_seed = {key: [by[last][s] for s in seeds] for key, by in values.items()
                if set(by.get(last, {})) == set(seeds)}
    budget = _budget(rows)
    of = "" if budget is None else f" of {budget / 1e6:.1f} M"
    state = ("finished: its final evaluation, eval.json, is the row's verdict (--compare)"
             if final else "under training")
    out += [f"{name}: {objective} on {env}, {state}; its last evaluation every seed reached, at "
            f"{last / 1e6:.1f} M{of} env steps per seed:", ""]
    named = options_line(name, trained_off_row(name, config))
    out += named + [""] * bool(named)
    segments = run_segments(name)
    logged_by = runs.segment_at(segments, last)  # its goals: the LGR's label
    out += VERDICT_HEADER + verdicts(dict(
        objective=objective, env=env, per_seed=per_seed,
        evaluated_on={"lgr_goals": logged_by.lgr_goals if logged_by else None}))
    balance = ablations.by_step(ablations.with_mode_balance(rows), ablations.BALANCE).get(last)
    if balance:  # D-min against a target of several modes
      mu, sd = mean_std(list(balance.values()))
      one = sum(b < ONE_MODE for b in balance.values())
      out += ["", f"Mode balance there (1: an even split; 0: one mode): {mu:.2f} ± {sd:.2f}; "
                  f"{one} of {len(balance)} seeds on one mode (balance below {ONE_MODE:g})."]
    # the paper's value is reached on the paper's goals only (an LGR on others is set apart)
    rows = ablations.with_lgr_goals(rows, segments)
    out += [""] + ablations.time_to_paper({objective: (objective, rows)}, env,
                                          tuple(k for k in keys if k in ablations.BETTER)) + [""]
  return "\n".join(out)


def final_point(evaluation: dict | None, key: str, window: str) -> list[float]:
  """The per-seed values of ``key`` in ``window`` ("Braxlines' window" or "blx's window") of a
  finished run's final evaluation (its ``eval.json``, read); ``[]`` where there is none, or where
  it is an LGR on other goals than the paper's."""
  if evaluation is None:
    return []
  if key == "eval/lgr" and not papers_goals(evaluation):
    return []
  suffix = "_braxlines" if window.startswith("Braxlines'") else ""
  return list(evaluation.get("per_seed", {}).get(key + suffix, []))


def draw_progress(path: str, *directories: str) -> list[str]:
  """``path``, a PNG: a row of panels per run with a paper row (``logged``), one per metric of the
  paper's table, each the run's curve (mean ± std over seeds, from ``metrics.csv``) over its whole
  budget of env steps, beside the paper's final value (mean ± std): how far a row has come, and
  where it stands against the paper. A finished run's final evaluation (``final_point``: the
  protocol's sizes, which the curve's evaluations during training need not have) is a marker at
  its last step. Runs of one row (env and algorithm) drawn together compare like with like: a
  metric is drawn in Braxlines' window only where every such run that logged it logged that window
  too (a run from before blx logged it has blx's alone), and their panels of it share one range of
  values. Returns the panels' titles, row by row."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  import ablations
  from blx.experiments import plots
  found = []
  for name, config, rows, final in logged(*directories):
    if isinstance(config, str):
      continue
    found.append((name, config, ablations.with_lgr_goals(rows, run_segments(name)), final))
  # per row, the metrics some run of it has in blx's window alone: every run of it draws them there
  blx_window: dict[tuple[str, str], set[str]] = {}
  for _, config, rows, _ in found:
    row = (config["env"], config["objective"])
    blx_window.setdefault(row, set()).update(
        c[0] for c in _paper_curves(rows, *row) if c[3].startswith("blx's") and c[4][0])
  panels = []
  for name, config, rows, final in found:
    env, objective = config["env"], config["objective"]
    curves = [c for c in _paper_curves(rows, env, objective,
                                       frozenset(blx_window[env, objective]))
              if c[-2][0] or c[-1][0]]
    if curves:
      base = os.path.basename(name)
      title = f"{env} {objective}" + ("" if base in (objective, f"objective={objective}")
                                      else f" ({base})")
      changed = trained_off_row(name, config)
      options = [f"{key} {value}" for key, (value, _) in changed.items()
                 if not key.startswith(OLDER)]
      title += f", option {', '.join(options)}" if options else ""
      title += "".join(f", {key} {value}" for key, (value, _) in changed.items()
                       if key.startswith(OLDER))
      evaluation = None
      if final:
        with open(final) as f:
          evaluation = json.load(f)
      panels.append((title + ("" if final else ", under training"),
                     _budget(rows) or 0.0, curves, evaluation, (env, objective)))
  if not panels:
    raise ValueError(f"nothing to draw under {', '.join(directories)}: no run there logged the "
                     "paper's metrics of a row of its tables (train with --eval-metrics)")
  titles = []
  columns = max(len(curves) for _, _, curves, _, _ in panels)
  fig, axes = plt.subplots(len(panels), columns, figsize=(max(5.2 * columns, 7.0),
                                                          3.2 * len(panels) + 0.6),
                           squeeze=False, layout="constrained")
  finals = False
  for row_axes, (title, budget, curves, evaluation, _) in zip(axes, panels):
    for ax, (key, mean, std, window, curve, other) in zip(row_axes, curves):
      for (steps, m, d), alpha, label in ((curve, 1.0, "blx (mean ± std over seeds)"),
                                          (other, 0.35, None)):
        x = [s / 1e6 for s in steps]
        ax.plot(x, m, "-", color="C0", alpha=alpha, label=label)
        ax.fill_between(x, [a - b for a, b in zip(m, d)], [a + b for a, b in zip(m, d)],
                        color="C0", alpha=0.2 * alpha)
      ax.axhline(mean, color="C3", linestyle="--", label="the paper's final value (mean ± std)")
      ax.axhspan(mean - std, mean + std, color="C3", alpha=0.1)
      final = final_point(evaluation, key, window) if curve[0] else []
      if final:
        finals = True
        final_mean, final_std = mean_std(final)
        ax.errorbar([curve[0][-1] / 1e6], [final_mean], yerr=[final_std], fmt="D",
                    color="k", ms=6, capsize=3, zorder=5,
                    label="blx's final evaluation, eval.json (mean ± std over seeds)")
      ax.set_xlim(0, max([budget] + curve[0] + other[0]) / 1e6 * 1.02)
      faded = "; faded: blx's old goals, not the paper's" if other[0] else ""
      titles.append(f"{title}; {window}{faded}")
      ax.set_title(textwrap.fill(titles[-1], 64), fontsize=9)
      ax.set_ylabel(ablations.LABELS.get(key, key), fontsize=8)
      ax.set_xlabel("env steps per seed (millions)")
      plots.value_axis(ax, key)
      ax.grid(alpha=0.3)
    for ax in row_axes[len(curves):]:
      ax.axis("off")
  by_key: dict[tuple, list] = {}  # one range of values per metric of a row, over its runs
  for row_axes, (_, _, curves, _, row) in zip(axes, panels):
    for ax, curve in zip(row_axes, curves):
      by_key.setdefault((*row, curve[0]), []).append(ax)
  for shared in by_key.values():
    limits = [ax.get_ylim() for ax in shared]
    for ax in shared:
      ax.set_ylim(min(lo for lo, _ in limits), max(hi for _, hi in limits))
  axes[0][0].legend(fontsize=7, loc="best")
  if finals:
    fig.supxlabel(textwrap.fill(progress_caption({row for *_, row in panels}),
                                200 if columns > 1 else 110), fontsize=8)
  fig.suptitle(textwrap.fill("The paper's rows during training: blx's curves against the "
                             "paper's final values", 70 if columns == 1 else 120), fontsize=10)
  fig.savefig(path, dpi=110)
  plt.close(fig)
  return titles


def progress_caption(rows) -> str:
  """``draw_progress``'s caption under the curves of ``rows`` (``(env, objective)`` pairs): the
  sizes the curves and the final marker are read at, and, for MI-max rows, which way the curves
  read MI against the final evaluation on the same policies (RESULTS, sessions 98-100)."""
  from blx.metrics.families import ROLLOUTS
  quick, final = ROLLOUTS["quick"], ROLLOUTS["final"]
  mimax = {objective for env, objective in rows
           if "eval/mi" in PAPER.get(env, {}).get(objective, {})}
  dmin = {objective for _, objective in rows} - mimax
  drawn, skills = mimax & DRAWN_LATENTS, mimax - DRAWN_LATENTS
  sizes = ([f"{quick} episodes of each skill"] if skills else []) + (
      [f"{quick} latents drawn from the prior, {quick} episodes each"] if drawn else []) + (
      [f"{quick} episodes"] if dmin else [])
  text = (f"The curves: the evaluations during training ({'; '.join(sizes)}); the black marker: "
          f"the final evaluation (eval.json, the paper's protocol: {final} where the curves have "
          f"{quick}).")
  if skills:
    text += (" Where measured (RESULTS, sessions 98-99) the curves read fixed skills' MI higher "
             "than the final evaluation of the same policies: fewer states and fewer courses per "
             "skill.")
  if drawn:
    text += (" Where measured (RESULTS, session 100) the curves read a continuous prior's MI "
             f"lower: {quick} latents cover less than {final}.")
  return text


def paper_steps(env: str) -> int:
  """The paper's env steps per seed: the env's PPO row (``experiments/defaults.py``) times 2."""
  return 2 * ppo_defaults(env).num_timesteps


def json_object(text: str, what: str) -> dict:
  """``text`` parsed as a JSON object; a ValueError says what it is instead (``what`` names the
  object wanted, e.g. "PPO settings")."""
  try:
    value = json.loads(text)
  except json.JSONDecodeError as e:
    raise ValueError(f"not JSON ({e})") from None
  if not isinstance(value, dict):
    raise ValueError(f"a JSON object of {what}, not {text}")
  return value


def ppo_config(text: str, env: str) -> dict:
  """The PPO settings a ``--config`` gives over the env's row: a JSON object whose keys and values
  ``PPOConfig`` takes. A ValueError names what is wrong (with the valid keys), before anything
  trains."""
  config = json_object(text, "PPO settings")
  ppo_defaults(env).replace(**config)
  return config


def specs(seeds: int, edits: dict | None = None, config: dict | None = None,
          steps: int | None = None, options: dict | None = None, env: str = "ant",
          first_seed: int = 0) -> dict:
  """The sweep specs of ``env``'s rows: ``{"gcrl" | "mimax" | "dmin": spec}``."""
  if env not in PAPER:
    raise ValueError(f"env {env!r}: the paper's tables have {list(ENVS)}")
  common = dict(env=env, seeds=list(range(first_seed, first_seed + seeds)),
                steps=paper_steps(env) if steps is None else steps,
                env_params=dict(edits=edits) if edits else {}, config=dict(config or {}))
  over = dict(options or {})
  return {
      # gcrl learns no discriminator, so spectral norm is not one of its options.
      "gcrl": dict(name=f"paper_gcrl_{env}", objective=["gcrl"],
                   options={"obs_indices": "vel", "obs_scale": 5.0, **over}, **common),
      "mimax": dict(name=f"paper_mimax_{env}", objective=["diayn", "cdiayn", "diayn_full"],
                    options={"obs_indices": "vel", "obs_scale": 5.0, "spectral_norm": True, **over},
                    **common),
      "dmin": dict(name=f"paper_dmin_{env}", objective=["gail", "gail2", "airl", "mle"],
                   options={"obs_indices": "vel", "obs_scale": 8.0, **over}, **common),
  }


def read_eval(path: str) -> tuple[str, dict]:
  """The ``eval.json`` at ``path``, a file or a directory holding exactly one (searched below it):
  ``(the file's path, its contents)``. ``ValueError`` naming what was found otherwise."""
  path = _one_file(path, "eval.json")
  with open(path) as f:
    return path, json.load(f)


def _one_file(path: str, kind: str, suffixed: bool = False) -> str:
  """``path`` where it is a file (named ``*KIND``, with ``suffixed``), else the one ``*KIND`` file
  below the directory ``path`` (e.g. ``eval.json``: a run's, or a committed row's
  ``NAME_eval.json``). ``ValueError`` naming what was found otherwise."""
  if os.path.isdir(path):
    found = sorted(glob.glob(os.path.join(path, "**", f"*{kind}"), recursive=True))
    if len(found) != 1:
      raise ValueError(f"{path}: {len(found)} {kind} files under it "
                       f"({', '.join(found) or 'none'}); give a run directory holding one, or "
                       "the file")
    path = found[0]
  if not os.path.isfile(path) or (suffixed and not path.endswith(kind)):
    article = "an" if kind[0] in "aeiou" else "a"
    raise ValueError(f"{path}: neither {article} {kind} file nor a directory holding one")
  return path


# Metrics where lower is better (a rise is worse), matched by name so that a metric's variants
# (e.g. Braxlines' window) count too; for every other metric higher is better.
LOWER_IS_BETTER = ("lgr", "energy_distance", "conditional_entropy")


def lower_is_better(metric: str) -> bool:
  """Whether a lower ``metric`` is better (``LOWER_IS_BETTER``)."""
  return any(word in metric for word in LOWER_IS_BETTER)


# Metrics ``paired`` reads beside the paper's, where both evaluations hold them: an MI's two parts,
# and the share of episodes that ran to the end (a body that falls ends its episode).
PAIRED_EXTRA = ("eval/conditional_entropy", "eval/alive_share")


def paired(a: dict, b: dict, names: tuple[str, str] = ("A", "B")) -> list[str]:
  """Markdown rows: the evaluations ``a`` and ``b`` of one env and algorithm (final ones, or
  ``logged_at``'s during training; say, an option's arm against the paper's row) on the seeds they
  share, paired by seed number (shared initial parameters and keys, not trajectories): per metric
  (the paper's for the row, then ``PAIRED_EXTRA``) each mean ± std (numpy's), the mean difference,
  the paired t-test, Welch's, and in how many seeds ``a`` is the better (larger, or smaller for an
  LGR, an energy distance or a conditional entropy). ``ValueError`` where they are not one row or
  share fewer than two seeds."""
  from scipy import stats
  row_a = (a.get("env", "ant"), a["objective"])
  row_b = (b.get("env", "ant"), b["objective"])
  if row_a != row_b:
    raise ValueError(f"{names[0]} is {row_a[1]} on {row_a[0]}, {names[1]} is {row_b[1]} on "
                     f"{row_b[0]}: a paired test needs one env and algorithm")
  goals = [(e.get("evaluated_on") or {}).get("lgr_goals") for e in (a, b)]
  shared = sorted(set(a["seeds"]) & set(b["seeds"]))
  if len(shared) < 2:
    raise ValueError(f"{names[0]} has seeds {a['seeds']}, {names[1]} {b['seeds']}: a paired test "
                     f"needs at least 2 shared seeds, got {shared}")
  env, objective = row_a
  metrics = [key.lstrip("-") for key in PAPER.get(env, {}).get(objective, {})]
  metrics += [m for m in PAIRED_EXTRA if m not in metrics]
  lines = [f"| metric | {names[0]} | {names[1]} | mean difference | paired t | p | Welch p "
           f"| seeds where {names[0]} is better |",
           "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
  for metric in metrics:
    if metric not in a["per_seed"] or metric not in b["per_seed"]:
      continue
    if metric == "eval/lgr" and goals[0] != goals[1]:
      lines.append(f"| {metric} | (not compared: goals {goals[0]} against {goals[1]}) "
                   "| | | | | | |")
      continue
    x = [a["per_seed"][metric][a["seeds"].index(s)] for s in shared]
    y = [b["per_seed"][metric][b["seeds"].index(s)] for s in shared]
    lower = lower_is_better(metric)
    t, p = stats.ttest_rel(x, y)
    welch_p = stats.ttest_ind(x, y, equal_var=False).pvalue
    better = sum((u < v) if lower else (u > v) for u, v in zip(x, y))
    (mx, sx), (my, sy) = mean_std(x), mean_std(y)
    label = f"{metric} (lower is better)" if lower else metric
    lines.append(f"| {label} | {mx:.3f} ± {sx:.3f} | {my:.3f} ± {sy:.3f} | {mx - my:+.3f} "
                 f"| {t:+.2f} | {p:.4f} | {welch_p:.4f} | {better} of {len(shared)} |")
  return lines


# How far from ``--at``'s env steps an evaluation during training may lie and still be taken for it.
AT_TOLERANCE = 0.02


def read_metrics(path: str) -> str:
  """The ``metrics.csv`` (or a committed row's ``NAME_metrics.csv``) at ``path``, a file or a
  directory holding exactly one (searched below it). ``ValueError`` naming what was found
  otherwise."""
  return _one_file(path, "metrics.csv", suffixed=True)


def logged_at(path: str, steps: float) -> tuple[str, dict]:
  """One run's evaluation during training (its ``metrics.csv``, logged with ``--eval-metrics``)
  at ``steps`` env steps per seed, in the form of a final evaluation (``eval.json``: ``env``,
  ``objective``, ``seeds``, ``per_seed`` and ``evaluated_on``, the LGR's goals as the run's
  provenance records them), so that ``paired`` reads it: ``(the metrics.csv's path, that
  evaluation)``. ``path`` as ``read_metrics`` takes it. The evaluation is the one every seed
  reached nearest ``steps``, within ``AT_TOLERANCE`` of it; ``per_seed`` holds every ``eval/``
  metric that every seed logged there. ``ValueError`` where the run has no config, or no such
  evaluation (naming those it has)."""
  import ablations  # its curves; it imports this module, so not at the top
  file = read_metrics(path)
  name, config, rows, _ = logged_run(file)
  if isinstance(config, str):
    raise ValueError(f"{file}: {config}")
  env, objective = config["env"], config["objective"]
  first = next((key.lstrip("-") for key in PAPER.get(env, {}).get(objective, {})), "eval/mi")
  values = ablations.by_step(rows, first)
  logged_steps = ablations.complete_steps(values)
  near = min(logged_steps, key=lambda s: abs(s - steps), default=None)
  if near is None or abs(near - steps) > AT_TOLERANCE * steps:
    listed = (", ".join(f"{s / 1e6:.2f} M" for s in logged_steps)
              or "none (a run trained without --eval-metrics logs none)")
    raise ValueError(f"{file}: no evaluation of {first} that every seed reached at "
                     f"{steps / 1e6:.2f} M env steps (within {AT_TOLERANCE:.0%}); it has {listed}")
  seeds = sorted(values[near])
  per_seed = {}
  for key in sorted({key for row in rows for key in row if key.startswith("eval/")}):
    at = ablations.by_step(rows, key).get(near, {})
    if set(at) == set(seeds):
      per_seed[key] = [at[seed] for seed in seeds]
  segment = runs.segment_at(run_segments(name), near)
  return file, dict(env=env, objective=objective, seeds=seeds, per_seed=per_seed, env_steps=near,
                    evaluated_on={"lgr_goals": segment.lgr_goals if segment else None})


def paired_report(path_a: str, path_b: str, at: float | None = None) -> str:
  """``paired`` for two ``eval.json`` files or run directories, with each one's settings that are
  not the original's (``options_line``) and its length where it is not the paper's
  (``length_line``) below the table. With ``at``, their evaluations during training at ``at`` env
  steps per seed (``logged_at``: ``metrics.csv`` files or run directories) rather than their
  final ones."""
  if at is None:
    (file_a, a), (file_b, b) = read_eval(path_a), read_eval(path_b)
  else:
    (file_a, a), (file_b, b) = logged_at(path_a, at), logged_at(path_b, at)
    if a["env_steps"] != b["env_steps"]:
      raise ValueError(f"{file_a} was evaluated at {a['env_steps']:,.0f} env steps, {file_b} at "
                       f"{b['env_steps']:,.0f}: pair evaluations at the same steps")
  names = (_short(file_a), _short(file_b))
  if names[0] == names[1]:
    names = ("A", "B")
  when = ("" if at is None else
          f" at {a['env_steps'] / 1e6:.2f} M env steps per seed (evaluations during training)")
  lines = [f"{names[0]}: {file_a} against {names[1]}: {file_b}, paired by seed{when}:", ""]
  lines += paired(a, b, names=names)
  notes = eval_options(file_a) + eval_options(file_b)
  return "\n".join(lines + ([""] + notes if notes else []))


def _short(path: str) -> str:
  """A column name for an eval.json or a metrics.csv: its run directory's name, or the file's
  prefix."""
  head, tail = os.path.split(path)
  for suffix in ("_eval.json", "_metrics.csv"):
    if tail.endswith(suffix):
      return tail[:-len(suffix)]
  return os.path.basename(head)


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", choices=ENVS, default="ant")
  parser.add_argument("--seeds", type=int, default=10)
  parser.add_argument("--first-seed", type=int, default=0,
                      help="train seeds FIRST .. FIRST + seeds - 1 (a row split over programs)")
  parser.add_argument("--only", choices=["gcrl", "mimax", "dmin"], default=None)
  parser.add_argument("--objective", default=None, help="train only this algorithm's point")
  parser.add_argument("--collect", action="store_true", help="only gather evaluated points")
  parser.add_argument("--out", default=None, help="default sweeps/paper_ENV")
  parser.add_argument("--env-edits", default=None, metavar="JSON",
                      help="edits of the env's desc for an ablation (dotted paths), e.g. "
                           "'{\"global_options.iterations\": 4}'")
  parser.add_argument("--config", default=None, metavar="JSON",
                      help="PPO settings over the env's row for an ablation, e.g. "
                           "'{\"normalize_advantage\": true}'")
  parser.add_argument("--options", default=None, metavar="JSON",
                      help="objective options over the row's for an ablation, e.g. "
                           "'{\"target_seed\": 3}'")
  parser.add_argument("--steps", type=int, default=None,
                      help="env steps per seed (default the paper's: the env's PPO row x 2; fewer "
                           "only for a diagnosis)")
  parser.add_argument("--eval-metrics", action="store_true",
                      help="log the paper's metrics at every evaluation during training")
  cli.add_eval_protocol_flag(parser)
  parser.add_argument("--compare", nargs="+", default=None, metavar="DIR",
                      help="only print the verdicts for the eval.json files under DIR; files at "
                           "the same path under several DIRs are one row's parts")
  parser.add_argument("--paired", nargs=2, default=None, metavar=("A", "B"),
                      help="only compare two final evaluations of one row (eval.json files or "
                           "run directories holding one), paired by seed: e.g. an option's arm "
                           "against the paper's row")
  parser.add_argument("--at", type=float, default=None, metavar="STEPS",
                      help="with --paired: pair the two runs' evaluations during training at "
                           "STEPS env steps per seed (their metrics.csv, logged with "
                           "--eval-metrics; e.g. 31.5e6) rather than their final ones")
  parser.add_argument("--progress", nargs="+", default=None, metavar="DIR",
                      help="only print where the runs under DIR stand during training (their "
                           "metrics.csv, logged with --eval-metrics) against the paper; DIR may "
                           "also be one run's metrics.csv (a committed row's NAME_metrics.csv)")
  parser.add_argument("--plot", default=None, metavar="PNG",
                      help="with --compare: also draw each row's final evaluation beside the "
                           "paper's value into PNG; with --progress: each run's curves")
  args = parser.parse_args()
  if sum(bool(x) for x in (args.compare, args.progress, args.paired)) > 1:
    parser.error("--compare, --progress and --paired: give one (the final verdicts, the rows' "
                 "progress, or two evaluations paired by seed)")
  if args.paired and args.plot:
    parser.error("--plot draws the rows of --compare or of --progress, not --paired's two "
                 "evaluations: leave it out, or draw them with --compare")
  if args.at is not None and not args.paired:
    parser.error("--at picks the evaluations --paired pairs: give --paired A B with it")
  if args.at is not None and args.at <= 0:
    parser.error(f"--at: env steps per seed must be positive, got {args.at:g}")
  if args.paired:
    try:
      print(paired_report(*args.paired, at=args.at))
    except ValueError as e:
      parser.error(f"--paired: {e}")
    return
  if args.compare:
    try:
      print(compare(*args.compare))
      if args.plot:
        draw_compare(args.plot, *args.compare)
        print(f"wrote {args.plot}")
    except ValueError as e:
      parser.error(f"--compare: {e}")
    return
  if args.plot and not args.progress:
    parser.error("--plot draws the rows of --compare (their final evaluations) or of --progress "
                 "(their curves): give one of them with it")
  if args.progress:
    try:
      print(progress(*args.progress))
      if args.plot:
        draw_progress(args.plot, *args.progress)
        print(f"wrote {args.plot}")
    except ValueError as e:
      parser.error(f"--progress: {e}")
    return
  known = [o for spec in specs(1).values() for o in spec["objective"]]
  if args.first_seed < 0:
    parser.error(f"--first-seed {args.first_seed}: must be >= 0")
  try:  # the run's own check, before anything trains
    runs.check_eval_protocol(args.out or "", args.eval_metrics, args.eval_protocol)
  except runs.RunError as e:
    parser.error(f"--eval-protocol: {e}")
  if args.objective and args.objective not in known:
    parser.error(f"--objective {args.objective!r}: valid ones are {known}")
  select = None
  if args.collect:
    select = lambda name, run_spec: False
  elif args.objective:
    select = lambda name, run_spec: run_spec.objective == args.objective
  args.out = args.out or f"sweeps/paper_{args.env}"
  parsed = {}  # each flag's JSON is checked before anything trains
  for flag, text, parse in (
      ("--env-edits", args.env_edits,
       lambda t: json_object(t, 'env edits (e.g. {"global_options.substeps": 8})')),
      ("--config", args.config, lambda t: ppo_config(t, args.env)),
      ("--options", args.options,
       lambda t: json_object(t, 'objective options (e.g. {"spectral_norm": false})'))):
    if text:
      try:
        parsed[flag] = parse(text)
      except ValueError as e:
        parser.error(f"{flag}: {e}")
  edits, config, options = (parsed.get(f) for f in ("--env-edits", "--config", "--options"))
  for family, spec in specs(args.seeds, edits, config, args.steps, options, args.env,
                              args.first_seed).items():
    if args.only and family != args.only:
      continue
    if args.objective and args.objective not in spec["objective"]:
      continue
    out = os.path.join(args.out, family)
    try:
      sweep.run_sweep(spec, out, select=select, eval_metrics=args.eval_metrics,
                      eval_protocol=args.eval_protocol)
    except KeyboardInterrupt:
      print(f"[paper_tables] {sweep.INTERRUPTED}", file=sys.stderr)
      raise SystemExit(cli.INTERRUPTED_STATUS)
    print(open(os.path.join(out, "summary.md")).read())
    if eval_files(out):
      print(compare(out))
    else:  # a run stopped before its end (a time limit) has no eval.json, so no verdict yet
      print(f"[paper_tables] {out}: no verdicts: no run there has finished (none has an "
            "eval.json)", file=sys.stderr)


if __name__ == "__main__":
  cli.run_main(main)  # an interrupted study ends at once, its checkpoints kept
