"""Sweeps: a grid (Cartesian product of lists) x seeds, one run directory per grid point, and an
aggregate table (mean +- std over seeds) as Markdown, CSV and LaTeX, shaped like the paper's
Tables 3 and 4.

A spec is a dict (from JSON, YAML, or a Python file defining ``SPEC``)::

    {"name": "mimax_point", "env": "point", "objective": ["diayn", "gcrl"], "seeds": [0, 1],
     "steps": 100000, "config": {"num_envs": 64}, "options": {"num_skills": 4}}

``agent`` (multi-agent envs) pays the objective to that agent only (``blx train --agent``).
Lists at the top level (``env``, ``objective``, ``steps``, ``agent``) or inside ``config`` /
``options`` / ``env_params`` are grid axes; ``seeds`` is vmapped inside each run. A setting whose
value is itself a list is a one-point axis: ``"policy_hidden": [[64, 64]]``.
"""

from __future__ import annotations

import csv
import itertools
import json
import os
import runpy
from typing import Any, Callable

from blx import metrics, training
from blx.experiments import runs
from blx.options import check_names
from blx.training import checkpoint

__all__ = ["load_spec", "check_spec", "expand", "run_sweep"]

_KEYS = {"name", "env", "objective", "seeds", "steps", "config", "options", "env_params", "out",
         "agent"}

# What a command that runs a sweep says when interrupted (Ctrl-C, or a timeout's SIGINT): running
# it again continues, as ``run_sweep`` reuses evaluated points and resumes the one in flight.
INTERRUPTED = ("interrupted: run the same command again to continue (evaluated points are kept; "
               "the point in flight resumes from its last whole checkpoint)")


def load_spec(path: str) -> dict:
  """Reads a sweep spec from .json, .yaml/.yml or .py (a module-level ``SPEC`` dict)."""
  if not os.path.isfile(path):
    raise ValueError(f"sweep spec {path!r} does not exist")
  ext = os.path.splitext(path)[1].lower()
  if ext not in (".json", ".yaml", ".yml", ".py"):
    raise ValueError(f"sweep spec {path!r}: use .json, .yaml, .yml or .py")
  try:
    if ext == ".json":
      with open(path) as f:
        spec = json.load(f)
    elif ext in (".yaml", ".yml"):
      import yaml
      with open(path) as f:
        spec = yaml.safe_load(f)
    else:
      spec = runpy.run_path(path).get("SPEC")
  except Exception as e:  # syntax errors of any of the three formats, or a failing .py
    first = str(e).splitlines()[0] if str(e) else ""
    raise ValueError(f"sweep spec {path!r} cannot be read: {type(e).__name__}: {first}") from None
  if not isinstance(spec, dict):
    raise ValueError(f"sweep spec {path!r}: expected a dict (a Python spec defines SPEC = {{...}})")
  check_spec(spec, f"sweep spec {path!r}")
  return spec


def check_spec(spec: dict, where: str = "sweep spec") -> None:
  """The spec's keys and the types of its fields, each named when wrong."""
  check_names(where, spec, sorted(_KEYS), "key")
  for key in ("env", "objective"):
    if key not in spec:
      raise ValueError(f"{where}: missing {key!r}")
  seeds = spec.get("seeds", [0])
  if not isinstance(seeds, list):
    raise ValueError(f"{where}: seeds must be a list of distinct ints in 0..2**31 - 1, e.g. "
                     f"[0, 1, 2], got {seeds!r}")
  training.check_seeds(seeds, f"{where}: seeds")
  for group in ("config", "options", "env_params"):
    if not isinstance(spec.get(group) or {}, dict):
      raise ValueError(f"{where}: {group} must be a mapping of setting -> value (or list of "
                       f"values), got {spec[group]!r}")
  for key in ("name", "out"):
    if key in spec and not isinstance(spec[key], str):
      raise ValueError(f"{where}: {key} must be a string, got {spec[key]!r}")
  name = spec.get("name")
  if name is not None and (not name or os.sep in name or "/" in name or name.startswith(".")):
    raise ValueError(f"{where}: name {name!r} must be a plain directory name (no '/' and not "
                     "starting with '.'); use out to choose where the sweep is written")


def _axes(spec: dict) -> list[tuple[tuple[str, ...], list]]:
  axes = []
  for key in ("env", "objective", "steps", "agent"):
    if isinstance(spec.get(key), list):
      axes.append(((key,), spec[key]))
  for group in ("config", "options", "env_params"):
    for key, value in (spec.get(group) or {}).items():
      if isinstance(value, list):
        axes.append(((group, key), value))
  return axes


def expand(spec: dict) -> list[tuple[str, runs.RunSpec]]:
  """The grid points as ``(name, RunSpec)``; names join ``key=value`` of the varied axes."""
  axes = _axes(spec)
  points = []
  for point in itertools.product(*[v for _, v in axes]) if axes else [()]:
    chosen = {path: v for (path, _), v in zip(axes, point)}
    get = lambda key: chosen.get((key,), spec.get(key))
    group = lambda g: {k: chosen.get((g, k), v) for k, v in (spec.get(g) or {}).items()}
    ppo = group("config")
    if get("steps") is not None:
      ppo["num_timesteps"] = int(get("steps"))
    run_spec = runs.RunSpec(env=get("env"), objective=get("objective"),
                            objective_options=group("options"), ppo=ppo,
                            seeds=tuple(int(s) for s in spec.get("seeds", [0])),
                            env_params=group("env_params"), agent=get("agent"))
    varied = {path: v for (path, options), v in zip(axes, point) if len(options) > 1}
    name = "__".join(f"{path[-1]}={_fmt(v)}" for path, v in varied.items()) or "run"
    points.append((name, run_spec))
  return points


def _fmt(v: Any) -> str:
  """A grid value as part of a directory name. A mapping (e.g. env ``edits``) is written
  ``key=value`` joined by ``,`` (``none`` when empty), without braces or quotes, so the name needs
  no quoting in a shell."""
  if isinstance(v, dict):
    return ",".join(f"{k}={_fmt(x)}" for k, x in v.items()) or "none"
  return str(v).replace("/", "-").replace(" ", "")


def _check_same_point(name: str, directory: str, run_spec: runs.RunSpec, desc: dict) -> None:
  """A point's directory is reused only for the same definition: env (its full desc, so a change
  of the library's bodies counts), objective and options, PPO config and steps, seeds, agent."""
  old = runs.read_spec(directory)
  pairs = {"env": (old.env, run_spec.env), "objective": (old.objective, run_spec.objective),
           "options": (old.objective_options, run_spec.objective_options),
           "config": (old.ppo, run_spec.ppo), "seeds": (list(old.seeds), list(run_spec.seeds)),
           "env_params": (old.env_params, run_spec.env_params),
           "agent": (old.agent, run_spec.agent), "desc": (old.desc, desc)}
  changed = [key for key, (a, b) in pairs.items() if runs.as_json(a) != runs.as_json(b)]
  if changed:
    detail = "; ".join(f"{k}: {runs.as_json(pairs[k][0])!r} -> {runs.as_json(pairs[k][1])!r}"
                       for k in changed if k != "desc")
    if "desc" in changed:
      detail = (detail + "; " if detail else "") + "the env's desc differs (the spec's env " \
                                                   "params or blx's bodies changed)"
    raise runs.RunError(f"sweep point {name!r} in {directory} was run with other settings "
                        f"({detail}); delete that directory to rerun it, or sweep into another "
                        "--out")


def run_sweep(spec: dict, out: str, *, progress=True, eval_metrics: bool = False,
              select: Callable[[str, runs.RunSpec], bool] | None = None,
              eval_protocol: str | None = None) -> list[dict]:
  """Trains and evaluates every grid point (reusing points already evaluated with the same
  definition; a point whose directory holds another definition is an error), then writes
  ``summary.md``, ``summary.csv`` and ``summary.tex`` in ``out``; returns the table rows.

  ``select(name, run_spec)``, if given, picks the points this call may train; the others enter
  the tables only if already evaluated (in ``out``). Several processes (one per GPU, say) can so
  share one sweep: each trains its own points, and a last call with ``select=lambda *_: False``
  gathers them all. ``eval_metrics`` and ``eval_protocol``: ``runs.train_run``'s, for every point
  this call trains (None: each point's own protocol where it resumes, else "quick").
  """
  check_spec(spec)
  runs.check_eval_protocol(out, eval_metrics, eval_protocol)  # before any directory is made
  points = expand(spec)
  # Build everything first so a bad option fails before any training; the tables ask
  # blx.metrics how each objective is measured.
  built = [runs.build(run_spec) for _, run_spec in points]
  families = [metrics.family_of(objective) for _, objective, _ in built]
  # What each point does, settled before the sweep's folder is made: a point whose directory holds
  # another definition, or a time setting a point to train cannot run with, is refused first.
  plan = []   # per point: its directory, whether it has started, whether this call trains it
  for (name, run_spec), point in zip(points, built):
    directory = os.path.join(out, name)
    started = os.path.exists(os.path.join(directory, "config.json"))
    if started:
      _check_same_point(name, directory, run_spec, point[0].desc)
    evaluated = os.path.exists(os.path.join(directory, "eval.json"))
    unfinished = _unfinished(directory) if evaluated else None
    if unfinished and progress:
      print(f"[blx sweep] {name}: its eval.json scored an unfinished run ({unfinished}); "
            "not a final evaluation", flush=True)
    trains = not (evaluated and not unfinished) and (select is None or select(name, run_spec))
    if trains:
      runs.check_time_settings(run_spec, directory, resume=started, built=point)
    plan.append((directory, started, trains))
  os.makedirs(out, exist_ok=True)
  rows = []
  for i, ((name, run_spec), (directory, started, trains)) in enumerate(zip(points, plan)):
    eval_path = os.path.join(directory, "eval.json")
    if trains:
      if progress:
        print(f"[blx sweep] {i + 1}/{len(points)}: {name}", flush=True)
      result = runs.train_run(run_spec, directory, resume=started, progress=progress,
                              eval_metrics=eval_metrics,
                              eval_protocol=eval_protocol).meta["eval"]
    # evaluated before, or by another process sharing the sweep (select) while this one trained
    elif os.path.exists(eval_path) and not _unfinished(directory):
      with open(eval_path) as f:
        result = json.load(f)
    else:
      continue
    rows.append({"name": name, "env": run_spec.env, "objective": run_spec.objective,
                 "family": families[i].name, "columns": families[i].table,
                 "summary": result["summary"], "seeds": len(run_spec.seeds)})
  write_tables(rows, out)
  return rows


def _unfinished(directory: str) -> str | None:
  """Where the run in ``directory`` stands if its checkpoint is not a whole run's
  (``training.checkpoint_progress``), else None (no checkpoint, or a finished one). A point's
  eval.json beside an unfinished checkpoint (earlier versions of ``blx eval`` wrote one there)
  does not end its training."""
  ckpt = os.path.join(directory, "checkpoint")
  if not checkpoint.exists(ckpt):
    return None
  meta = checkpoint.read_meta(ckpt)
  return None if training.checkpoint_finished(meta) else training.checkpoint_progress(meta)


def _cell(summary: dict, key: str, sign: float) -> tuple[str, float, float]:
  if key not in summary:
    return "-", float("nan"), float("nan")
  mean, std = sign * summary[key]["mean"], summary[key]["std"]
  return f"{mean:.3f} ± {std:.3f}", mean, std


def write_tables(rows: list[dict], out: str) -> None:
  """One table per family (MI-max, D-min, task, ...), rows = grid points, as Markdown, CSV and
  LaTeX; each family's columns are those ``blx.metrics`` registers for it."""
  md, tex, csv_rows = [], [], []
  for family in dict.fromkeys(r["family"] for r in rows):
    group = [r for r in rows if r["family"] == family]
    cols = group[0]["columns"]
    md.append(f"| run | seeds | {' | '.join(c for c, _, _ in cols)} |")
    md.append("| --- | ---: |" + " ---: |" * len(cols))
    tex.append("\\begin{tabular}{l" + "c" * (len(cols) + 1) + "}\n\\toprule")
    tex.append("run & seeds & " + " & ".join(c.replace("±", "$\\pm$") for c, _, _ in cols)
               + " \\\\\n\\midrule")
    for r in group:
      cells = [_cell(r["summary"], key, sign) for _, key, sign in cols]
      md.append(f"| {r['name']} | {r['seeds']} | " + " | ".join(c[0] for c in cells) + " |")
      tex.append(r["name"].replace("_", "\\_") + f" & {r['seeds']} & " + " & ".join(
          c[0].replace("±", "$\\pm$") for c in cells) + " \\\\")
      row = {"family": family, "run": r["name"], "env": r["env"], "objective": r["objective"],
             "seeds": r["seeds"]}
      for (label, _, _), (_, mean, std) in zip(cols, cells):
        row[f"{label} mean"], row[f"{label} std"] = mean, std
      csv_rows.append(row)
    md.append("")
    tex.append("\\bottomrule\n\\end{tabular}\n")
  with open(os.path.join(out, "summary.md"), "w") as f:
    f.write("\n".join(md))
  with open(os.path.join(out, "summary.tex"), "w") as f:
    f.write("\n".join(tex))
  columns = list(dict.fromkeys(k for r in csv_rows for k in r))
  with open(os.path.join(out, "summary.csv"), "w", newline="") as f:
    writer = csv.DictWriter(f, columns)
    writer.writeheader()
    writer.writerows(csv_rows)

