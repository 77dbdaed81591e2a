"""MI(s_d, z) and H(s_d) per observation dimension d of trained MI-max runs: the paper's feature
engineering figures (DIAYN on xy velocity against DIAYN_FULL on the whole observation, Ant, the
first 30 dimensions), #15.

    python benchmarks/feature_dims.py RUN_DIR [RUN_DIR ...] [--dims 30] [--seeds 0,1,2]
                                      [--labels A,B] [--out feature_dims.png]

Each run's policy is rolled out as the paper's MI evaluation does (every skill, 10 episodes each,
sampled actions, the last 500 steps), for every seed of the run, or for the positions in its seeds
that ``--seeds`` names. Each dimension's particle MI and H(s) (Algorithm 1, 1000 bins over
+-obs_scale of the run's objective) are averaged over those seeds. One figure with two panels (MI
per dimension, H(s) per dimension; each dimension named from the env's layout), one bar per run and
dimension (``--labels`` names the runs in the legend; default each run's objective), and a JSON
beside it with the numbers and the seeds.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402


def scan(env: Any, objective: Any, policy: Callable, params: Any, dims, key: jax.Array, *,
         episodes_per_latent: int = 10, last_steps: int = 500, bins: int = 1000) -> dict:
  """``{"mi": [D], "entropy": [D]}`` of observation dims ``dims`` for one policy (one seed); pure,
  so it runs under ``jax.jit``."""
  from blx.metrics import evaluate, particle
  dims = np.asarray(dims)
  z_key, roll_key = jax.random.split(key)
  latents = evaluate.latents_for_evaluation(objective, z_key, 10)
  states = evaluate.rollout(env, policy, params, latents, roll_key,
                            episodes_per_latent=episodes_per_latent)[..., dims]
  states = states[:, :, -last_steps:]
  num = latents.shape[0]
  labels = jnp.repeat(jnp.arange(num), states.shape[1] * states.shape[2])
  scale = objective.spec.obs_scale
  out = particle.mutual_information(states.reshape(-1, len(dims)), labels, bins=bins,
                                    value_range=(-scale, scale), num_labels=num)
  return {"mi": out["mi"], "entropy": out["entropy"]}


def scan_run(directory: str, dims, seed: int = 0, positions: list[int] | None = None) -> dict:
  """Per-dimension MI and H(s) of the seeds at ``positions`` (default every one) of the run in
  ``directory``: ``{"mi": [S, D], "entropy": [S, D]}``."""
  from blx.experiments import runs
  run = runs.load_run(directory)
  fn = jax.jit(lambda p, k: scan(run.env, run.objective, run.policy, p, dims, k))
  if positions is None:
    positions = range(len(run.spec.seeds))
  per_seed = [fn(jax.tree.map(lambda x: x[i], run.params), jax.random.PRNGKey(seed))
              for i in positions]
  return {key: np.stack([np.asarray(s[key]) for s in per_seed]) for key in ("mi", "entropy")}


def plot(results: dict[str, dict], dims, path: str, *, labels: list[str] | None = None,
         title: str = "") -> None:
  """Two panels of bars: mean over seeds (error bar: std) per dimension, one colour per run;
  ``labels`` name the dimensions on the x axis (default their indices)."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  dims = list(dims)
  fig, axes = plt.subplots(2, 1, figsize=(max(8, 0.4 * len(dims) * len(results)),
                                          6 if labels is None else 8), sharex=True)
  width = 0.8 / len(results)
  x = np.arange(len(dims))
  for ax, key, name in zip(axes, ("mi", "entropy"), ("MI(s_d, z) (nats)", "H(s_d) (nats)")):
    for j, (run, r) in enumerate(results.items()):
      ax.bar(x + (j - (len(results) - 1) / 2) * width, r[key].mean(0), width,
             yerr=r[key].std(0) if r[key].shape[0] > 1 else None, label=run, capsize=1.5)
    ax.set_ylabel(name)
    ax.grid(axis="y", alpha=0.3)
  axes[0].legend(fontsize=10)
  if labels is None:
    axes[1].set_xticks(x, [str(d) for d in dims], fontsize=7)
  else:
    axes[1].set_xticks(x, labels, fontsize=7, rotation=90)
  axes[1].set_xlabel("observation dimension")
  axes[0].set_title((f"{title}: " if title else "")
                    + "MI and H(s) per observation dimension (mean ± std over seeds)", fontsize=12)
  fig.tight_layout()
  fig.savefig(path, dpi=120)
  plt.close(fig)


def run_labels(specs: dict) -> dict[str, str]:
  """``{directory: legend entry}``: the objective's name, with the directory's name where that
  says more than the objective (a sweep point's ``lr=0.001``), or with the whole path where two
  runs would otherwise share an entry."""
  labels = {}
  for directory, spec in specs.items():
    name = os.path.basename(os.path.normpath(directory))
    labels[directory] = (spec.objective if name in (spec.objective, f"objective={spec.objective}")
                         else f"{spec.objective} ({name})")
  if len(set(labels.values())) < len(labels):
    labels = {directory: f"{spec.objective} ({directory})" for directory, spec in specs.items()}
  return labels


def main(argv: list[str] | None = None):
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("runs", nargs="+", help="run directories (blx train / sweep points)")
  parser.add_argument("--dims", type=int, default=30, help="the first N observation dimensions")
  parser.add_argument("--seeds", default=None,
                      help="comma-separated positions in each run's seeds (default all)")
  parser.add_argument("--labels", default=None,
                      help="comma-separated legend entries, one per run (default the objectives)")
  parser.add_argument("--out", default="feature_dims.png")
  args = parser.parse_args(argv)
  from blx import envs
  from blx.experiments import plots, runs
  if len(set(args.runs)) < len(args.runs):
    parser.error(f"a run directory is given twice: {args.runs}")
  names = None
  if args.labels is not None:
    names = [name.strip() for name in args.labels.split(",")]
    if len(names) != len(args.runs) or len(set(names)) < len(names) or not all(names):
      parser.error(f"--labels {args.labels!r}: give {len(args.runs)} distinct names, one per run")
  specs = {directory: runs.read_spec(directory) for directory in args.runs}
  picked = {}
  for directory, spec in specs.items():
    try:
      picked[directory] = common.seed_positions(args.seeds, len(spec.seeds))
    except ValueError as e:
      parser.error(f"{directory}: {e}")
  env, _, _ = runs.build(specs[args.runs[0]])
  size = envs.unwrap(env).observation_size
  if not 1 <= args.dims <= size:
    parser.error(f"--dims {args.dims}: the observation has {size} dimensions")
  dims = list(range(args.dims))
  results, seeds = {}, {}
  legend = run_labels(specs) if names is None else dict(zip(args.runs, names))
  for directory, label in legend.items():
    results[label] = scan_run(directory, dims, positions=picked[directory])
    seeds[label] = [specs[directory].seeds[i] for i in picked[directory]]
  counts = sorted({len(s) for s in seeds.values()})
  plot(results, dims, args.out, labels=plots.feature_labels(env, dims),
       title=f"{specs[args.runs[0]].env}, {'/'.join(map(str, counts))} "
             f"seed{'s' if counts != [1] else ''}")
  common.write_json(os.path.splitext(args.out)[0] + ".json",
                    {k: {**{m: v.tolist() for m, v in r.items()}, "seeds": seeds[k]}
                     for k, r in results.items()})
  for label, r in results.items():
    mi = r["mi"].mean(0)
    top = np.argsort(-mi)[:5]
    print(f"{label}: highest MI at dims {top.tolist()} ("
          + ", ".join(f"{mi[d]:.3f}" for d in top) + ")")


if __name__ == "__main__":
  main()
