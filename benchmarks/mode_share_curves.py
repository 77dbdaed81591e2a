"""How a D-min run shares its samples among the target's modes over training, per seed.

    python benchmarks/mode_share_curves.py LABEL=metrics.csv [LABEL=metrics.csv ...] --out PNG

Reads runs trained with ``--eval-metrics`` (``blx train`` or ``benchmarks/paper_tables.py``), whose
``metrics.csv`` holds ``eval/mode_share/0``, ``eval/energy_distance`` and ``policy/entropy`` at
every evaluation, and draws one column per run: the share of samples nearest mode 0, the energy
distance and the policy's entropy against env steps, one line per seed.
"""

from __future__ import annotations

import argparse
import csv
from collections import defaultdict

PANELS = (("eval/mode_share/0", "share of samples nearest mode 0"),
          ("eval/energy_distance", "energy distance to the target"),
          ("policy/entropy", "policy entropy (tanh Gaussian)"))


def read(path: str) -> dict[str, dict[str, list[float]]]:
  """seed -> column -> values in step order (rows without an evaluation are skipped)."""
  runs: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
  with open(path) as f:
    for row in csv.DictReader(f):
      if not row.get(PANELS[0][0]):
        continue
      for key in ("env_steps",) + tuple(k for k, _ in PANELS):
        runs[row["seed"]][key].append(float(row[key]))
  if not runs:
    raise SystemExit(f"{path}: no rows with {PANELS[0][0]}; train with --eval-metrics")
  return runs


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("runs", nargs="+", metavar="LABEL=metrics.csv")
  parser.add_argument("--out", required=True)
  parser.add_argument("--title", default="")
  args = parser.parse_args()
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  arms = []
  for item in args.runs:
    label, sep, path = item.partition("=")
    if not sep:
      parser.error(f"{item!r}: give LABEL=path/to/metrics.csv")
    arms.append((label, read(path)))
  fig, axes = plt.subplots(len(PANELS), len(arms), figsize=(4.2 * len(arms), 8.5), sharex=True,
                           sharey="row", squeeze=False)
  for col, (label, runs) in enumerate(arms):
    for row, (key, name) in enumerate(PANELS):
      ax = axes[row][col]
      for seed, values in sorted(runs.items()):
        ax.plot([s / 1e6 for s in values["env_steps"]], values[key], marker=".", label=f"seed {seed}")
      if key == "eval/mode_share/0":
        ax.axhline(0.5, color="grey", lw=0.8, ls="--")
      if row == 0:
        ax.set_title(label)
      if col == 0:
        ax.set_ylabel(name)
      if row == len(PANELS) - 1:
        ax.set_xlabel("env steps per seed (millions)")
      ax.grid(alpha=0.3)
  axes[0][0].legend(fontsize=8)
  if args.title:
    fig.suptitle(args.title)
  fig.tight_layout()
  fig.savefig(args.out, dpi=110)
  print(args.out)


if __name__ == "__main__":
  main()
