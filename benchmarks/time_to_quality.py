"""Wall time to the paper's quality: how long from start until DIAYN on Ant first reaches the
paper's MI (1.115) and GAIL on Ant the paper's energy distance (0.802), for several num_envs.

    python benchmarks/time_to_quality.py [--objectives diayn,gail] [--num-envs 2048,8192,16384,32768]
        [--seeds 4] [--first-seed 0] [--steps 60000000] [--budget-s 600] [--num-evals 40]
        [--config JSON] [--out DIR] [--env ant] [--threshold NAME=VALUE ...] [--quick-eval]
        [--arm LABEL=JSON ...] [--options JSON] [--compile-cache DIR|off]

Every arm is one ``training.train`` with the paper's objective settings (those of
``paper_tables.py``: 8 DIAYN skills on the xy velocity, obs_scale 5, spectral norm; GAIL to the
bimodal xy-velocity target, obs_scale 8) and the env's PPO row with ``num_envs`` set, keeping the
row's batch (1,024 x 32 minibatches for the ant), so that every num_envs takes the paper's SGD
steps per env step (session 9: with ``batch_size = num_envs // 2`` at 16,384 envs DIAYN barely
learned), unless ``--config`` says otherwise. Each
``--arm LABEL=JSON`` adds one recipe (PPO settings over ``--config``), run at every num_envs, e.g.
``--arm 'instep={"staggered_starts": false}'`` (``PPOConfig`` staggers the starts above 2,048 envs
by default); without ``--arm`` there is one. ``--options JSON`` sets objective options over the
paper's for every arm (e.g. ``'{"gradient_penalty_weight": 1.0}'``, not the original's setting:
``summary.md`` names them). After each of ``--num-evals`` chunks the paper's
evaluator (sampled actions; ``--quick-eval``: 4 episodes, every 10th step) scores every seed.
The clock starts before the env is built, so env compilation, XLA compilation and the evaluations
all count, as a user's wall time would. An arm stops when the mean over seeds reaches the
threshold, at ``--budget-s`` or at ``--steps``.

Writes ``DIR/<objective>_<num_envs>[_<label>].json`` (every evaluation: wall seconds, env steps, the metric
per seed), ``DIR/summary.md`` and ``DIR/time_to_quality.png`` (the metric against wall seconds,
one line per num_envs, the paper's value dashed). DIR defaults to ``$OUT`` or
``benchmarks/ttq``. Compare settings only within one call on one device.
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import paper_tables  # noqa: E402

from blx import training  # noqa: E402
from blx.training.loop import parallel_compile_default  # noqa: E402
from blx.experiments import plots, runs  # noqa: E402

# objective -> (metric key, the paper's value, whether larger is better)
QUALITY = {"diayn": ("eval/mi", 1.115, True), "gail": ("eval/energy_distance", 0.802, False)}


class _Stop(Exception):
  pass


def arm_spec(env: str, objective: str, num_envs: int, seeds: int, steps: int, num_evals: int,
             config: dict, first_seed: int = 0, options: dict | None = None) -> runs.RunSpec:
  """The paper's objective settings (``options`` over them) and the env's PPO row with
  ``num_envs`` and ``config`` over it."""
  family = next(spec for spec in paper_tables.specs(seeds).values()
                if objective in spec["objective"])
  ppo = {"num_envs": num_envs, "num_timesteps": steps, "num_evals": num_evals, **config}
  return runs.RunSpec(env=env, objective=objective,
                      objective_options={**family["options"], **(options or {})},
                      ppo=ppo, seeds=tuple(range(first_seed, first_seed + seeds)))


def run_arm(spec: runs.RunSpec, key: str, threshold: float, larger: bool, budget_s: float,
            quick: bool) -> dict:
  start = time.time()
  env, objective, config = runs.build(spec)
  evaluator = runs.evaluator_for(env, objective, quick=quick)
  rows = []

  def record(row):
    values = [float(v) for v in np.atleast_1d(row[key])]
    rows.append({"wall_s": time.time() - start, "env_steps": row["env_steps"], "values": values,
                 "mean": float(np.mean(values)), "compile_s": row.get("compile_seconds")})
    print(json.dumps({"objective": spec.objective, "num_envs": spec.ppo["num_envs"],
                      **rows[-1]}), flush=True)
    reached = rows[-1]["mean"] >= threshold if larger else rows[-1]["mean"] <= threshold
    if reached or rows[-1]["wall_s"] > budget_s:
      raise _Stop

  try:
    training.train(env, objective, config, seeds=spec.seeds, progress=record, evaluate=evaluator)
  except _Stop:
    pass
  better = (lambda v: v >= threshold) if larger else (lambda v: v <= threshold)
  first = next((r for r in rows if better(r["mean"])), None)
  per_seed = [next((r["wall_s"] for r in rows if better(r["values"][i])), None)
              for i in range(len(spec.seeds))]
  # The settings given, and the batch they came to (the row's unless given).
  ppo = {**spec.ppo, "batch_size": config.batch_size, "num_minibatches": config.num_minibatches,
         "starts_staggered": config.starts_staggered}
  return {"objective": spec.objective, "num_envs": spec.ppo["num_envs"], "ppo": ppo,
          "metric": key, "threshold": threshold, "rows": rows,
          "time_to_quality_s": first and first["wall_s"],
          "steps_to_quality": first and first["env_steps"], "per_seed_time_s": per_seed,
          "best_mean": (max if larger else min)(r["mean"] for r in rows) if rows else None,
          "wall_s": time.time() - start}


def plot(results: list[dict], path: str) -> list[str]:
  """Writes the figure to ``path``; returns the legend's labels of the arms."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  names = list(dict.fromkeys(r["objective"] for r in results))
  labels = []
  fig, axes = plt.subplots(1, len(names), figsize=(5.2 * len(names), 4.8), squeeze=False)
  for ax, name in zip(axes.flat, names):
    arms = [r for r in results if r["objective"] == name]
    for i, r in enumerate(arms):
      t = [row["wall_s"] for row in r["rows"]]
      v = np.array([row["values"] for row in r["rows"]])
      if not len(t):
        continue
      staggered = r["ppo"].get("starts_staggered")
      label = (f"{r['num_envs']:,} envs, batch {r['ppo']['batch_size']:,}"
               + (f" x {r['ppo']['num_minibatches']}" if r["ppo"].get("num_minibatches") else "")
               + {True: ", staggered starts", False: ", starts in step"}.get(staggered, "")
               + (f", {r['label']}" if r.get("label") else ""))
      ax.plot(t, v.mean(1), "o-", ms=3, color=f"C{i}", label=label)
      labels.append(label)
      if v.shape[1] > 1:
        ax.fill_between(t, v.min(1), v.max(1), color=f"C{i}", alpha=0.15)
    key, value = arms[0]["metric"], arms[0]["threshold"]
    paper = value == QUALITY.get(name, (None, None))[1]
    ax.axhline(value, color="k", ls="--", lw=1,
               label=f"the paper's value, {value}" if paper else f"quality bar {value} (not the paper's)")
    ax.set_xlim(0, 1.05 * max([row["wall_s"] for r in arms for row in r["rows"]] or [1.0]))
    ax.set_xlabel("wall seconds from start (compilation and evaluations included)", fontsize=8)
    ax.set_ylabel(plots.curve_ylabel(key), fontsize=9)
    ax.set_title(f"{name} on {arms[0].get('env', 'ant')}", fontsize=10)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2))  # below: no curve hidden
  seeds = len(results[0]["rows"][0]["values"]) if results and results[0]["rows"] else 1
  fig.text(0.5, 0.005, "one seed" if seeds == 1 else
           f"line: mean over {seeds} seeds, band: lowest to highest seed",
           ha="center", va="bottom", fontsize=7, color="0.3")
  fig.tight_layout(rect=(0, 0.04, 1, 1))
  fig.savefig(path, dpi=90)
  plt.close(fig)
  return labels


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="ant")
  parser.add_argument("--objectives", default="diayn,gail")
  parser.add_argument("--num-envs", default="2048,8192,16384,32768")
  parser.add_argument("--seeds", type=int, default=4)
  parser.add_argument("--first-seed", type=int, default=0,
                      help="seeds run are first-seed .. first-seed + seeds - 1")
  parser.add_argument("--steps", type=int, default=60_000_000)
  parser.add_argument("--budget-s", type=float, default=600.0, help="wall seconds per arm")
  parser.add_argument("--num-evals", type=int, default=40)
  parser.add_argument("--config", default=None, metavar="JSON",
                      help="PPO settings for every arm, e.g. '{\"learning_rate\": 6e-4}'")
  parser.add_argument("--threshold", action="append", default=[], metavar="OBJECTIVE=VALUE",
                      help="another quality bar than the paper's (for a quick check only)")
  parser.add_argument("--quick-eval", action="store_true")
  parser.add_argument("--options", default=None, metavar="JSON",
                      help="objective options over the paper's for every arm, e.g. "
                           "'{\"gradient_penalty_weight\": 1.0}' (not the original's setting)")
  parser.add_argument("--arm", action="append", default=[], metavar="LABEL=JSON",
                      help="a recipe run at every num_envs: PPO settings over --config, e.g. "
                      "'instep={\"staggered_starts\": false}' (repeatable)")
  parser.add_argument("--compile-cache", default="off", metavar="DIR|off",
                      help="JAX's persistent compilation cache in DIR, as `blx train` keeps it "
                      "by default (run twice: cold, then warm); 'off' (the default) compiles "
                      "everything, as sessions 9-14 measured")
  parser.add_argument("--out", default=None)
  args = parser.parse_args()
  cache = None
  if args.compile_cache.lower() != "off":
    from blx.experiments import compile_cache
    cache = compile_cache.enable(args.compile_cache)
    if cache is None:
      parser.error(f"--compile-cache {args.compile_cache!r}: the directory cannot be used")
  out = args.out or os.environ.get("OUT") or os.path.join("benchmarks", "ttq")
  os.makedirs(out, exist_ok=True)
  config = json.loads(args.config) if args.config else {}
  options = {}
  if args.options:
    try:
      options = paper_tables.json_object(args.options, 'objective options (e.g. {"spectral_norm": '
                                         'false})')
    except ValueError as e:
      parser.error(f"--options: {e}")
  quality = dict(QUALITY)
  for item in args.threshold:
    name, _, value = item.partition("=")
    if name not in quality:
      parser.error(f"--threshold {item!r}: valid objectives are {sorted(quality)}")
    quality[name] = (quality[name][0], float(value), quality[name][2])
  arms = []
  for item in args.arm or ["="]:
    label, _, text = item.partition("=")
    if label and not label.replace("_", "").replace("-", "").isalnum():
      parser.error(f"--arm {item!r}: the label must be letters, digits, '-' or '_'")
    try:
      settings = json.loads(text) if text else {}
    except json.JSONDecodeError:
      settings = None
    if not isinstance(settings, dict):
      parser.error(f"--arm {item!r}: the settings after '=' must be a JSON object, e.g. "
                   "'instep={\"staggered_starts\": false}'")
    arms.append((label, {**config, **settings}))
  names = args.objectives.split(",")
  for name in names:  # every objective and its options checked before the first arm's clock
    if name not in quality:
      parser.error(f"--objectives: {name!r} is not one of {sorted(quality)}")
    if options:
      try:
        runs.build(arm_spec(args.env, name, 8, 1, 1, 1, {}, options=options))
      except ValueError as e:
        parser.error(f"--options for {name}: {e}")
  results = []
  for name in names:
    key, threshold, larger = quality[name]
    for n, (label, settings) in itertools.product(
        [int(x) for x in args.num_envs.split(",")], arms):
      spec = arm_spec(args.env, name, n, args.seeds, args.steps, args.num_evals, settings,
                      args.first_seed, options)
      result = {"env": args.env, "label": label, "objective_options": spec.objective_options,
                **run_arm(spec, key, threshold, larger, args.budget_s, args.quick_eval)}
      results.append(result)
      with open(os.path.join(out, f"{name}_{n}{'_' + label if label else ''}.json"), "w") as f:
        json.dump(result, f, indent=1)
      plot(results, os.path.join(out, "time_to_quality.png"))
  import jax
  seeds = f"seeds {args.first_seed}..{args.first_seed + args.seeds - 1} vmapped" if args.seeds > 1 \
      else f"seed {args.first_seed}"
  lines = [f"{args.env}, {seeds}, up to {args.steps:,} steps or "
           f"{args.budget_s:.0f} s per arm; jax {jax.__version__} on "
           f"{jax.devices()[0].device_kind}; PPO overrides {config or 'none'}; objective options "
           f"over the paper's {options or 'none'}; compilation "
           f"cache {cache or 'off'}; compiled in parallel: {parallel_compile_default()}",
           "",
           "| objective | num_envs | batch | recipe | time to quality (s) | env steps then | "
           "per-seed times (s) | best mean | compile (s) |",
           "| --- | ---: | ---: | --- | ---: | ---: | --- | ---: | ---: |"]
  for r in results:
    t = f"{r['time_to_quality_s']:.0f}" if r["time_to_quality_s"] else f"not in {r['wall_s']:.0f}"
    steps = f"{r['steps_to_quality']:,.0f}" if r["steps_to_quality"] else "-"
    seeds = ", ".join("-" if s is None else f"{s:.0f}" for s in r["per_seed_time_s"])
    comp = r["rows"][0]["compile_s"] if r["rows"] else None
    recipe = r["label"] or "-"
    lines.append(f"| {r['objective']} | {r['num_envs']:,} | {r['ppo']['batch_size']:,} | {recipe} | {t} | "
                 f"{steps} | {seeds} | {r['best_mean']:.3f} | "
                 f"{'-' if comp is None else f'{comp:.0f}'} |")
  text = "\n".join(lines)
  print(text)
  with open(os.path.join(out, "summary.md"), "w") as f:
    f.write(text + "\n")


if __name__ == "__main__":
  main()
