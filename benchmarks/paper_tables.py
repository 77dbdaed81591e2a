"""The paper's Ant rows (Tables 3 and 4) through the sweep machinery of ``blx sweep``.

    python benchmarks/paper_tables.py [--seeds 5] [--only gcrl|mimax|dmin] [--objective diayn]
                                      [--collect] [--out sweeps/paper]

``--objective`` trains only that algorithm's point (one process per GPU:
``CUDA_VISIBLE_DEVICES=i python benchmarks/paper_tables.py --objective NAME &`` for each), and
``--collect`` then gathers every evaluated point into the tables without training.

MI-max: gcrl, diayn, cdiayn, diayn_full on the ant's xy velocity, obs_scale 5, spectral norm on;
D-min: gail, gail2, airl, mle to the bimodal xy-velocity target (modes (+-4, 0), std 0.8), obs_scale
8, spectral norm off. PPO: the ant row with twice its steps (60 M), seeds vmapped in one program per
algorithm. Writes summary.md / .csv / .tex per sweep and prints them beside the paper's values.
"""

from __future__ import annotations

import argparse
import os

from blx.experiments import sweep

PAPER = {
    "diayn": "1.115 ± 0.268 | 5.558 ± 0.286 | -2.260 ± 0.539",
    "diayn_full": "0.034 ± 0.006 | 5.044 ± 0.039 | -3.010 ± 0.010",
    "gcrl": "1.218 ± 0.192 | 6.066 ± 0.051 | -2.074 ± 0.232",
    "cdiayn": "0.750 ± 0.185 | 5.253 ± 0.270 | -2.885 ± 0.291",
    "airl": "-2.588 ± 1.194", "gail": "-0.802 ± 0.460", "gail2": "-2.898 ± 0.946",
    "mle": "-1.829 ± 0.573",
}


def specs(seeds: int) -> dict:
  common = dict(env="ant", seeds=list(range(seeds)), steps=60_000_000)
  return {
      # gcrl learns no discriminator, so spectral norm is not one of its options.
      "gcrl": dict(name="paper_gcrl_ant", objective=["gcrl"],
                   options=dict(obs_indices="vel", obs_scale=5.0), **common),
      "mimax": dict(name="paper_mimax_ant", objective=["diayn", "cdiayn", "diayn_full"],
                    options=dict(obs_indices="vel", obs_scale=5.0, spectral_norm=True), **common),
      "dmin": dict(name="paper_dmin_ant", objective=["gail", "gail2", "airl", "mle"],
                   options=dict(obs_indices="vel", obs_scale=8.0), **common),
  }


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--seeds", type=int, default=5)
  parser.add_argument("--only", choices=["gcrl", "mimax", "dmin"], default=None)
  parser.add_argument("--objective", default=None, help="train only this algorithm's point")
  parser.add_argument("--collect", action="store_true", help="only gather evaluated points")
  parser.add_argument("--out", default="sweeps/paper")
  args = parser.parse_args()
  known = [o for spec in specs(1).values() for o in spec["objective"]]
  if args.objective and args.objective not in known:
    parser.error(f"--objective {args.objective!r}: valid ones are {known}")
  select = None
  if args.collect:
    select = lambda name, run_spec: False
  elif args.objective:
    select = lambda name, run_spec: run_spec.objective == args.objective
  for family, spec in specs(args.seeds).items():
    if args.only and family != args.only:
      continue
    if args.objective and args.objective not in spec["objective"]:
      continue
    out = os.path.join(args.out, family)
    rows = sweep.run_sweep(spec, out, select=select)
    print(open(os.path.join(out, "summary.md")).read())
    for row in rows:
      print(f"paper {row['objective']}: {PAPER.get(row['objective'], '-')}")


if __name__ == "__main__":
  main()
