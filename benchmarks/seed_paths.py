"""Where every seed's skills take the agent (#15): one figure, a row per run directory (e.g. the
arms of an ablation) and a column per seed, each panel the xy paths of the agent's root body under
every skill. The run's own ``plots/paths.png`` shows seed 0 only, and a study's claim about skills
("SN makes cDIAYN's skills distinct") is about every seed.

    python benchmarks/seed_paths.py RUN_DIR [RUN_DIR ...] [--seeds 0,1] [--deterministic]
                                    [--labels A,B] [--title TEXT] [--out FILE.png]

Each run must be an MI-max run (skills: the K one-hots of a categorical prior, or 8 draws of a
continuous prior, the same draws for every seed and run) with its checkpoint. Each panel draws
``EPISODES`` episodes per skill, one colour per skill (the same colour means the same latent across
panels), circles at the first recorded positions and dots at the last; actions are sampled as in
the paper's evaluation unless ``--deterministic``. A panel's title is its seed and its ``eval/mi``
from the run's ``eval.json``, where there is one. All panels share one scale, so a row of short
paths is a run whose skills move little. Writes ``--out`` (default ``seed_paths.png`` in the first
run directory) and beside it the same name ending in ``.json``: per run, its seeds, their MI and
their reach (the straight-line distance an episode covers, in metres, averaged over skills and
episodes); the reach is also printed per run.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import jax
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import metrics  # noqa: E402
from blx.experiments import plots, runs  # noqa: E402
from blx.objectives.specs import MimaxSpec  # noqa: E402

EPISODES = 3
CONTINUOUS_SKILLS = 8  # draws of a continuous prior, as the run's own skills plot


def seed_paths(run: runs.Run, positions: list[int], *, deterministic: bool) -> np.ndarray:
  """The root body's xy over each episode, ``[S, L, M, T, 2]`` for the seeds at ``positions``:
  ``L`` skills, ``EPISODES`` episodes each. Every seed draws the same latents."""
  z_key, roll_key = jax.random.split(jax.random.PRNGKey(0))
  latents = metrics.latents_for_evaluation(run.objective, z_key, CONTINUOUS_SKILLS)
  params = jax.tree.map(lambda x: x[np.asarray(positions)], run.params)
  keys = jax.random.split(roll_key, len(positions))

  def one(p, k):
    return metrics.rollout(run.env, run.policy, p, latents, k, episodes_per_latent=EPISODES,
                           deterministic=deterministic,
                           record=lambda state, action, next_state: plots.root_xy(next_state))

  return np.asarray(jax.jit(jax.vmap(one))(params, keys))


def reach(xy: np.ndarray) -> np.ndarray:
  """How far each seed's skills carry the agent, ``[S]`` from ``xy [S, L, M, T, 2]``: the
  straight-line distance from an episode's first recorded position to its last, averaged over
  skills and episodes."""
  return np.linalg.norm(xy[..., -1, :] - xy[..., 0, :], axis=-1).mean((1, 2))


def seed_mis(directory: str, seeds: list[int]) -> list[float | None]:
  """Each seed's ``eval/mi`` from the run's ``eval.json`` (None where it has none)."""
  path = os.path.join(directory, "eval.json")
  if not os.path.exists(path):
    return [None] * len(seeds)
  with open(path) as f:
    evaluation = json.load(f)
  by_seed = dict(zip(evaluation["seeds"], evaluation["per_seed"].get("eval/mi", [])))
  return [by_seed.get(s) for s in seeds]


def draw(rows: list[tuple[str, list[int], list[float | None], np.ndarray]], path: str, *,
         body: str, title: str) -> None:
  """The figure: ``rows`` of ``(label, seeds, mis, xy [S, L, M, T, 2])``, one panel per seed."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  columns = max(len(seeds) for _, seeds, _, _ in rows)
  fig, axes = plt.subplots(len(rows), columns, figsize=(1.9 * columns + 0.6, 2.1 * len(rows) + 0.8),
                           squeeze=False)
  every = np.concatenate([xy.reshape(-1, 2) for *_, xy in rows])
  centre = (every.max(0) + every.min(0)) / 2
  half = (every.max(0) - every.min(0)).max() / 2 * 1.05 + 1e-6
  for r, (label, seeds, mis, xy) in enumerate(rows):
    colours = plots.skill_colours(xy.shape[1])
    for c in range(columns):
      ax = axes[r, c]
      if c >= len(seeds):
        ax.axis("off")
        continue
      plots.draw_paths(ax, xy[c], colours, width=0.7, end_size=5, start_size=14)
      ax.set_xlim(centre[0] - half, centre[0] + half)
      ax.set_ylim(centre[1] - half, centre[1] + half)
      ax.set_aspect("equal")
      ax.tick_params(labelsize=6)
      mi = "" if mis[c] is None else f", MI {mis[c]:.2f}"
      ax.set_title(f"seed {seeds[c]}{mi}", fontsize=7)
      if c == 0:
        ax.set_ylabel(f"{label}\n\ny (m)", fontsize=8)
      if r == len(rows) - 1:
        ax.set_xlabel("x (m)", fontsize=7)
  fig.suptitle(plots.fit_title(title, fig), fontsize=10)
  caption = (f"{body}'s xy over {EPISODES} episodes per skill, one colour per skill (the same "
             "latent in every panel); circles: the first positions, dots: the last. One scale "
             "for all panels.")
  fig.text(0.5, 0.005, plots.fit_title(caption, fig, 7), ha="center", va="bottom",
           fontsize=7, color="0.3")
  fig.tight_layout(rect=(0, 0.025, 1, 1))
  fig.savefig(path, dpi=110)
  plt.close(fig)


def _load(directory: str, parser) -> runs.Run:
  try:
    run = runs.load_run(directory)
  except runs.RunError as e:
    parser.error(str(e))
  if not isinstance(run.objective.spec, MimaxSpec):
    parser.error(f"{directory}: {run.spec.objective} has no skills (valid: an MI-max objective, "
                 "e.g. diayn, cdiayn, diayn_full, gcrl)")
  return run


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  parser.add_argument("runs", nargs="+", help="MI-max run directories (config.json and checkpoint)")
  parser.add_argument("--seeds", default=None,
                      help="comma-separated positions in each run's seeds (default all)")
  parser.add_argument("--deterministic", action="store_true", help="take the mean actions")
  parser.add_argument("--labels", default=None,
                      help="comma-separated row names, one per run (default the runs' names)")
  parser.add_argument("--title", default=None, help="the figure's title")
  parser.add_argument("--out", default=None, help="default RUN_DIR/seed_paths.png (the first run)")
  args = parser.parse_args(argv)
  labels = (args.labels.split(",") if args.labels is not None
            else [os.path.basename(os.path.normpath(d)) for d in args.runs])
  if len(labels) != len(args.runs) or len(set(labels)) != len(labels):
    parser.error(f"--labels: {len(labels)} names for {len(args.runs)} runs; give one distinct "
                 "name per run")
  if args.out is not None and not args.out.endswith(".png"):
    parser.error(f"--out {args.out!r}: give a .png path")
  loaded = [_load(d, parser) for d in args.runs]  # every run checked before any rollout
  rows, bodies, summary = [], set(), {}
  for directory, label, run in zip(args.runs, labels, loaded):
    try:
      positions = common.seed_positions(args.seeds, len(run.spec.seeds))
    except ValueError as e:
      parser.error(f"{directory}: {e}")
    seeds = [run.spec.seeds[p] for p in positions]
    bodies.add(plots.root_body(run.env))
    xy = seed_paths(run, positions, deterministic=args.deterministic)
    rows.append((label, seeds, seed_mis(directory, seeds), xy))
    far = reach(xy)
    summary[label] = {"run": directory, "seeds": seeds, "mi": rows[-1][2],
                      "reach_m": [round(float(d), 3) for d in far]}
    print(f"{directory}: {len(seeds)} seeds, {xy.shape[1]} skills; reach {far.mean():.1f} +- "
          f"{far.std():.1f} m (per seed: {' '.join(f'{d:.1f}' for d in far)})")
  actions = "mean actions" if args.deterministic else "sampled actions"
  label = common.run_label(loaded[0].spec, "every seed", directory=loaded[0].directory)
  title = args.title or f"{label}: paths ({actions})"
  out = args.out or os.path.join(args.runs[0], "seed_paths.png")
  draw(rows, out, body=" / ".join(sorted(bodies)), title=title)
  common.write_json(os.path.splitext(out)[0] + ".json", summary)
  print(f"wrote {out}")
  return 0


if __name__ == "__main__":
  sys.exit(main())
