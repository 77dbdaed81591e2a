"""Where a discrete-skill MI-max row loses its MI (#15): how the scored feature spreads within an
episode, between the episodes of a skill, and between skills.

    python benchmarks/skill_spread.py RUN_DIR [--seeds 0,1] [--deterministic] [--window W]
                                              [--out FILE.json]
    python benchmarks/skill_spread.py RUN_DIR --plot [--seed 0]   # skill_spread.png

The paper's MI estimator (Algorithm 1) bins every scored state of every episode of a skill together.
MI = H(s) - H(s|z) is at most ln K for K skills, reached when no two skills' states share a bin.
A skill whose body moves at a steady mean speed but whose speed swings within each stride spreads
over many bins. Where the swing reaches a neighbouring skill's speeds, the two share bins: H(s|z)
grows and MI falls though their mean speeds differ. Skills that settle at one speed share their
bins too. This script measures which of the two costs the MI.

Per seed and observed dimension d, on the protocol's episodes (every skill's one-hot, 10 episodes
each, the last 500 steps scored, actions sampled unless ``--deterministic``):
- ``mi``, ``entropy``, ``cond_entropy``: the protocol's MI, H(s) and H(s|z) = H(s) - MI (as
  ``eval/mi`` and ``eval/entropy``, on other random episodes);
- ``effective_skills``: exp(MI), the number of equally likely, fully separated skills that would
  score this MI (K at most). Skills that run at one speed count as one;
- ``share_between_skills``, ``share_between_episodes``, ``share_within_episode``: the law of total
  variance over the scored states. The variance of the skills' means, of the episode means around
  their skill's mean, and of the states around their episode's mean (the stride), each over the
  total. They sum to 1;
- ``stride_std``: the root mean within-episode variance, in the feature's units;
- ``skill_gap``: the median gap between neighbouring skill means (sorted), in the same units;
  ``gap_over_stride`` is the ratio. Below about 2, neighbouring skills' states overlap (two
  normal distributions 2 std apart share about a third of their mass);
- ``skill_means``: every skill's mean, sorted (a list per seed);
- ``mi_smoothed``: a diagnostic, never the protocol. The same estimator on the feature averaged over
  the ``--window`` steps up to each state (default 20), which removes most of a stride's swing.
  How much MI the swing costs;
- ``share_out_of_range``: the share of the scored states outside the histogram's range
  [-obs_scale, obs_scale]. The estimator counts them in N but in no bin, so a skill that runs
  beyond the range adds to neither H(s) nor its H(s|z): one of K equally likely skills wholly
  outside costs ln K / K of the MI, however well it is separated;
- ``mi_wide``: a diagnostic, never the protocol. The same estimator with bins of the same width
  over twice the range (2 x 1000 bins over [-2 obs_scale, 2 obs_scale]), where it counts those
  states. How much MI the range costs.

Prints the mean +- std over seeds and ln K; writes every per-seed value to ``--out`` (default
RUN_DIR/skill_spread.json or skill_spread_deterministic.json).

``--plot`` draws RUN_DIR/skill_spread.png for ``--seed`` (a position in the run's seeds): each
skill's histogram of the scored feature (its first dimension), 100 steps of one episode of each
skill, and, from skill_spread.json, every seed's variance shares. Its episodes are new random ones.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import metrics  # noqa: E402
from blx.experiments import plots, runs  # noqa: E402

BINS = 1000
EPISODES = 10


def episodes(run: runs.Run, params, key: jax.Array, *, deterministic: bool) -> jax.Array:
  """The protocol's episodes of every skill: the observed feature ``[K, M, T, D]`` (whole episodes,
  T the episode's policy steps)."""
  indices = np.asarray(metrics.eval_indices(run.objective))
  z_key, roll_key = jax.random.split(key)
  latents = metrics.latents_for_evaluation(run.objective, z_key, 10)
  return metrics.rollout(run.env, run.policy, params, latents, roll_key,
                         episodes_per_latent=EPISODES, deterministic=deterministic,
                         record=lambda s, a, n: n.obs[..., indices])


def trailing_mean(x: jax.Array, window: int) -> jax.Array:
  """The mean of the ``window`` values up to and including each step, along axis -2 of
  ``[..., T, D]`` (fewer at the start of the episode)."""
  c = jnp.cumsum(x, axis=-2)
  shifted = jnp.concatenate([jnp.zeros_like(c[..., :window, :]), c[..., :-window, :]], axis=-2)
  count = jnp.minimum(jnp.arange(1, x.shape[-2] + 1), window)[:, None]
  return (c - shifted) / count


def spread(states: jax.Array, scale: float, last: int, window: int) -> dict:
  """The module's per-seed figures from whole episodes ``states`` ``[K, M, T, D]``."""
  k, m, _, d = states.shape
  scored = states[:, :, -last:]                                   # [K, M, T', D]
  labels = jnp.repeat(jnp.arange(k), m * last)
  # The protocol's estimator; with ``reach`` 2, its bins' width over twice the range (mi_wide).
  mi = lambda x, reach=1: metrics.mutual_information(
      x.reshape(-1, d), labels, bins=reach * BINS, value_range=(-reach * scale, reach * scale),
      num_labels=k)
  protocol = mi(scored)
  smoothed = mi(trailing_mean(states, window)[:, :, -last:])
  wide = mi(scored, reach=2)
  outside = (jnp.abs(scored) > scale).mean((0, 1, 2))
  episode_mean = scored.mean(2)                                   # [K, M, D]
  skill_mean = episode_mean.mean(1)                               # [K, D]
  within = scored.var(2).mean((0, 1))
  between_episodes = episode_mean.var(1).mean(0)
  between_skills = skill_mean.var(0)
  total = within + between_episodes + between_skills
  ordered = jnp.sort(skill_mean, axis=0)
  gap = jnp.median(jnp.diff(ordered, axis=0), axis=0)
  stride = jnp.sqrt(within)
  return {"mi": protocol["mi"], "entropy": protocol["entropy"],
          "cond_entropy": protocol["entropy"] - protocol["mi"],
          "effective_skills": jnp.exp(protocol["mi"]),
          "share_between_skills": between_skills / total,
          "share_between_episodes": between_episodes / total,
          "share_within_episode": within / total,
          "stride_std": stride, "skill_gap": gap, "gap_over_stride": gap / stride,
          "skill_means": ordered.T, "mi_smoothed": smoothed["mi"],
          "share_out_of_range": outside, "mi_wide": wide["mi"]}


def _check_run(run: runs.Run, parser) -> None:
  common.require_discrete_skills(run, parser, "this analysis splits the scored states by skill")


def plot(run: runs.Run, position: int, *, deterministic: bool) -> str:
  """Draws ``RUN_DIR/skill_spread.png`` (see the module's doc) and returns its path."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  params = jax.tree.map(lambda x: x[position], run.params)
  key = jax.random.split(jax.random.PRNGKey(2), len(run.spec.seeds))[position]
  states = np.asarray(jax.jit(lambda p, k: episodes(run, p, k, deterministic=deterministic))(
      params, key))[..., 0]                                       # [K, M, T]
  scale = run.objective.spec.obs_scale
  last = metrics.scored_steps(run.env)
  scored = states[:, :, -last:]
  k = scored.shape[0]
  mi = float(spread(jnp.asarray(states[..., None]), scale, last, 1)["mi"][0])
  order = np.argsort(scored.mean((1, 2)))
  colors = plots.skill_colours(k)
  analysis_path = os.path.join(run.directory, "skill_spread.json")
  analysis = None
  if os.path.exists(analysis_path):
    with open(analysis_path) as f:
      analysis = json.load(f)
  fig, axes = plt.subplots(1, 3 if analysis else 2, figsize=(16 if analysis else 11, 4))
  (name,) = plots.feature_labels(run.env, metrics.eval_indices(run.objective)[:1])
  ax = axes[0]
  reach = max(scale, float(np.abs(scored).max()))
  edges = np.linspace(-reach, reach, 201)
  for s in order:
    ax.hist(scored[s].ravel(), bins=edges, color=colors[s], alpha=0.6,
            label=f"skill {s}: mean {scored[s].mean():+.2f}")
  if reach > scale:  # states the estimator counts in no bin
    for side in (-scale, scale):
      ax.axvline(side, color="k", ls="--", lw=1,
                 label="the estimator's range (+-obs_scale)" if side > 0 else None)
  ax.set_xlabel(f"{name}, the scored feature")
  ax.set_ylabel("scored states")
  ax.set_title(f"each skill's scored states ({EPISODES} episodes x {last} steps)", fontsize=9)
  ax.set_ylim(top=ax.get_ylim()[1] * 1.4)  # room above the bars for the legend
  ax.legend(fontsize=7, ncol=2, loc="upper center")
  ax = axes[1]
  dt = getattr(run.env, "dt", None)
  steps = np.arange(100)
  x = steps * dt if dt else steps
  for s in order:
    ax.plot(x, scored[s, 0, :100], color=colors[s], lw=1)
  ax.set_xlabel("seconds into the scored window" if dt else "policy steps into the scored window")
  ax.set_ylabel(name)
  ax.set_title("one episode of each skill, its first 100 scored steps", fontsize=9)
  ax.grid(alpha=0.3)
  if analysis:
    ax = axes[2]
    v = analysis["per_seed"]
    seeds = np.arange(len(analysis["seeds"]))
    bottom = np.zeros(len(seeds))
    for key_, label, color in (("share_between_skills", "between skills' means", "C2"),
                               ("share_between_episodes", "between a skill's episodes", "C1"),
                               ("share_within_episode", "within an episode (the stride)", "C3")):
      share = np.asarray(v[key_])[:, 0]
      ax.bar(seeds, share, bottom=bottom, color=color, label=label)
      bottom += share
    ax.set_xticks(seeds, [str(s) for s in analysis["seeds"]])
    ax.set_xlabel("seed")
    ax.set_ylabel("share of the scored feature's variance")
    ax.set_ylim(0, 1)
    actions = "mean" if analysis["deterministic"] else "sampled"
    ax.set_title(f"every seed: where the variance is ({actions} actions)", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")
  label = common.run_label(run.spec, f"seed {run.spec.seeds[position]}", directory=run.directory)
  fig.suptitle(plots.fit_title(
      f"{label}: MI {mi:.2f} of ln {k} = {math.log(k):.2f} nats on these episodes", fig),
      fontsize=10)
  fig.tight_layout()
  path = os.path.join(run.directory, "skill_spread.png")
  fig.savefig(path, dpi=120)
  plt.close(fig)
  return path


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  common.add_analysis_arguments(parser, "an MI-max run directory with discrete skills "
                                "(config.json and checkpoint)")
  parser.add_argument("--window", type=int, default=None,
                      help="steps averaged for mi_smoothed (a diagnostic; default 20)")
  parser.add_argument("--plot", action="store_true",
                      help="only draw skill_spread.png for --seed")
  parser.add_argument("--seed", type=int, default=None,
                      help="the seed position --plot draws (default 0)")
  args = parser.parse_args(argv)
  if args.plot:
    unused = [f for f, v in (("--seeds", args.seeds), ("--window", args.window),
                             ("--out", args.out)) if v is not None]
    if unused:
      parser.error(f"{', '.join(unused)}: not used by --plot, which draws one --seed")
  elif args.seed is not None:
    parser.error("--seed picks the seed --plot draws; the analysis takes --seeds")
  try:
    run = runs.load_run(args.run)
  except runs.RunError as e:
    parser.error(str(e))
  _check_run(run, parser)
  n = len(run.spec.seeds)
  try:
    picked = (common.seed_positions(str(args.seed or 0), n, "--seed") if args.plot
              else common.seed_positions(args.seeds, n))
  except ValueError as e:
    parser.error(str(e))
  if args.plot:
    print(f"wrote {plot(run, picked[0], deterministic=args.deterministic)}")
    return 0
  last = metrics.scored_steps(run.env)
  window = 20 if args.window is None else args.window
  if not 1 <= window <= last:
    parser.error(f"--window {window}: give 1..{last} (the scored steps)")
  params, keys = common.picked_seeds(run, picked, 1)
  scale = run.objective.spec.obs_scale

  def one(p, k):
    return spread(episodes(run, p, k, deterministic=args.deterministic), scale, last, window)

  values = {k: np.asarray(v).tolist() for k, v in jax.jit(jax.vmap(one))(params, keys).items()}
  k = len(values["skill_means"][0][0])
  result = {"run": os.path.abspath(args.run), "seeds": [run.spec.seeds[p] for p in picked],
            "deterministic": args.deterministic, "window": window, "num_skills": k,
            "ln_num_skills": math.log(k), "per_seed": values}
  name = "skill_spread_deterministic.json" if args.deterministic else "skill_spread.json"
  out = args.out or os.path.join(args.run, name)
  common.write_json(out, result)
  actions = "mean" if args.deterministic else "sampled"
  print(f"{run.spec.objective} on {run.spec.env}, seeds {result['seeds']}, {actions} actions, "
        f"ln K = {math.log(k):.3f}")
  print(common.seed_table({k: v for k, v in values.items() if k != "skill_means"},
                          "metric (per observed dimension)"))
  print(f"wrote {out}")
  return 0


if __name__ == "__main__":
  sys.exit(main())
