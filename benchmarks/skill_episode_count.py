"""How an MI-max row's MI depends on the number of episodes per skill it is read from (#15): the
quick protocol's 4 (the curves logged during training) against the final evaluation's 10
(``eval.json``, the paper's), and why; for a continuous prior (cDIAYN, GCRL) also on the number of
latents drawn, 4 in the quick protocol and 10 in the final.

    python benchmarks/skill_episode_count.py RUN_DIR [--seeds 0,1] [--pool 20] [--sizes 1,2,4,10,20]
                                                [--latents 4,10] [--states 2000] [--draws 200]
                                                [--deterministic] [--out FILE.json]
    python benchmarks/skill_episode_count.py RUN_DIR --plot   # skill_episode_count.png

The paper's estimator (Algorithm 1) reads H(s) and H(s|z) from histograms of every scored state of
a skill's episodes. Read from fewer episodes it reads H(s|z) lower, and MI higher, for two reasons
this script tells apart:

- **fewer states**: a plug-in entropy of N states on 1,000 bins reads lower the smaller N is (its
  bias, about -(bins taken - 1) / 2N, shrinks as N grows), though the states come from the same
  distribution;
- **fewer courses**: each episode of a skill takes a course of its own (its speed, its heading, the
  moment it falls), and a few episodes hold fewer of the skill's courses than many do.

Per seed, the policy of the run's checkpoint (its last; ``env_steps`` in the JSON says where)
rolls out ``--pool`` episodes of every skill (as the protocol's evaluator: actions sampled unless
``--deterministic``, the last half of each episode scored, at most 500 steps). Then for each k in ``--sizes``, ``--draws`` times, k of the pooled episodes of
each skill are drawn (without replacement, each skill its own) and read two ways:

- ``mi/k``, ``entropy/k``, ``cond_entropy/k``: every scored step of the k episodes, as an
  evaluation of k episodes per skill reads them (the protocols: k = 4 quick, 10 final);
- ``mi_fixed_states/k``, ``entropy_fixed_states/k``, ``cond_entropy_fixed_states/k``:
  ``--states`` states per skill whatever k (default the quick protocol's: 4 episodes x the scored
  steps), ``--states`` / k evenly spaced steps of each episode's scored window; only for k that
  divide ``--states`` into shares that fit the window.

Where the fixed-state reading stays level in k while ``mi/k`` falls, the number of states makes the
gap; where it falls as ``mi/k`` does, the number of courses. Each value is the mean over the draws
(``*_std``: their std, how far one evaluation moves); with k = the pool every draw is the same.

A continuous prior has no fixed skills: the evaluator draws latents from it (the paper's num_z)
and reads each as a skill, so the MI it can read is at most ln of their number, ln 4 = 1.39 in
the quick protocol and ln 10 = 2.30 in the final. Here ``--pool`` latents are drawn per seed, each
rolled out ``--pool`` times, and every reading is taken for each m of ``--latents`` (default the
protocols' 4 and 10): m of the pooled latents drawn at random, then k episodes of each. Its keys
carry m: ``mi/<m>_latents/<k>``. The quick protocol reads (m, k) = (4, 4), the final (10, 10).

Writes ``--out`` (default RUN_DIR/skill_episode_count.json; ``--deterministic``:
skill_episode_count_deterministic.json) and prints the table; ``--plot`` draws
RUN_DIR/skill_episode_count.png from it.
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

BINS = 1000  # the protocol's (metrics.mimax_evaluator)
QUICK, FINAL = 4, 10  # episodes per skill, and latents drawn, of the protocols (ROLLOUTS)
READINGS = (("mi", "cond_entropy", "entropy"), ("mi_fixed_states", "cond_entropy_fixed_states",
                                               "entropy_fixed_states"))


def pooled_episodes(run, params, key: jax.Array, pool: int, *, deterministic: bool) -> jax.Array:
  """``pool`` episodes of every skill (a continuous prior: of each of ``pool`` latents drawn),
  their scored window of the observed feature ``[K, pool, T, D]``."""
  indices = np.asarray(metrics.eval_indices(run.objective))
  z_key, roll_key = jax.random.split(key)
  latents = metrics.latents_for_evaluation(run.objective, z_key, pool)
  states = metrics.rollout(run.env, run.policy, params, latents, roll_key,
                           episodes_per_latent=pool, deterministic=deterministic,
                           record=lambda s, a, n: n.obs[..., indices])
  return states[:, :, -metrics.scored_steps(run.env):]


def evenly_spaced(length: int, count: int) -> np.ndarray:
  """``count`` distinct steps of ``length`` spread evenly over it, the last one included."""
  return np.round(np.linspace(0, length - 1, count)).astype(int)


def read_subsets(scored: jax.Array, key: jax.Array, k: int, draws: int, scale: float,
                 steps: int | None = None, latents: int | None = None) -> dict:
  """The estimator on ``draws`` random sets of ``k`` of each skill's pooled episodes
  ``scored [K, P, T, D]``, every scored step (``steps`` None) or ``steps`` evenly spaced ones of
  each episode: ``{mi, entropy, cond_entropy}``, each ``{"mean": [D], "std": [D]}`` over draws.
  With ``latents`` m (a continuous prior's pooled draws), each set reads m of the K at random,
  each its own label; None reads all K (a categorical prior's skills)."""
  num, pool, length, dims = scored.shape
  m = num if latents is None else latents
  at = jnp.asarray(evenly_spaced(length, steps if steps is not None else length))
  labels = jnp.repeat(jnp.arange(m), k * at.shape[0])

  def one(draw_key):
    if latents is None:   # every skill; the draw's key picks the episodes, as before --latents
      read, episode_key = scored, draw_key
    else:
      latent_key, episode_key = jax.random.split(draw_key)
      read = scored[jax.random.permutation(latent_key, num)[:m]]      # [m, P, T, D]
    picks = jax.vmap(lambda s: jax.random.permutation(s, pool)[:k])(
        jax.random.split(episode_key, m))                            # [m, k]
    chosen = jnp.take_along_axis(read, picks[:, :, None, None], axis=1)[:, :, at]
    out = metrics.mutual_information(chosen.reshape(-1, dims), labels, bins=BINS,
                                     value_range=(-scale, scale), num_labels=m)
    return out["mi"], out["entropy"], out["conditional_entropy"]

  mi, h, hz = jax.lax.map(one, jax.random.split(key, draws))
  return {name: {"mean": v.mean(0), "std": v.std(0)}
          for name, v in (("mi", mi), ("entropy", h), ("cond_entropy", hz))}


def reading_key(name: str, k: int, latents: int | None = None) -> str:
  """A reading's key in ``per_seed``: ``name/k``, or ``name/<m>_latents/k`` for m latents."""
  return f"{name}/{k}" if latents is None else f"{name}/{latents}_latents/{k}"


def readings(scored: jax.Array, key: jax.Array, sizes, draws: int, scale: float,
             states: int, latent_counts=None) -> dict:
  """Per seed: ``{"<reading>/<k>": [D], "<reading>_std/<k>": [D]}`` for every k of ``sizes`` (and
  every m of ``latent_counts``, keyed by ``reading_key``; None: all K skills), the fixed-state
  readings only where ``states`` / k steps fit each episode's scored window."""
  fixed = fixed_state_sizes(sizes, states, scored.shape[2])
  out = {}
  for m in latent_counts or (None,):
    for k in sizes:
      key, every_key, fixed_key = jax.random.split(key, 3)
      arms = [(READINGS[0], read_subsets(scored, every_key, k, draws, scale, latents=m))]
      if k in fixed:
        arms.append((READINGS[1], read_subsets(scored, fixed_key, k, draws, scale, states // k,
                                               latents=m)))
      for names, got in arms:
        for name, base in zip(names, ("mi", "cond_entropy", "entropy")):
          out[reading_key(name, k, m)] = got[base]["mean"]
          out[reading_key(name + "_std", k, m)] = got[base]["std"]
  return out


def fixed_state_sizes(sizes, states: int, length: int) -> list[int]:
  """The sizes whose fixed-state reading exists: ``states`` split evenly over k episodes, each
  share within the scored window."""
  return [k for k in sizes if states % k == 0 and states // k <= length]


def plot(result: dict, path: str) -> str:
  """Draws ``path`` from a result of ``main``: MI and H(s|z) of the first observed dimension
  against episodes per skill, each seed faint, their mean bold, both readings (and, for a
  continuous prior, each number of latents), the protocols' k marked."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  v = result["per_seed"]
  sizes = result["sizes"]
  fixed = result["fixed_state_sizes"]
  counts = result.get("latent_counts") or [None]
  unit = "skill" if counts == [None] else "latent"
  fig, axes = plt.subplots(1, 2, figsize=(12, 4.8 if len(counts) > 1 else 4.4))
  for ax, (every, fixed_name, label) in zip(axes, (
      ("mi", "mi_fixed_states", "MI(s, z)"),
      ("cond_entropy", "cond_entropy_fixed_states", "H(s | z)"))):
    for m, style, marker in zip(counts, ("-", "--", "-.", ":"), ("o", "s", "^", "v")):
      of = "" if m is None else f"{m} latents, "
      for name, ks, color, text in (
          (every, sizes, "C0", f"every scored step of k episodes (k x {result['scored_steps']} "
           f"states per {unit})"),
          (fixed_name, fixed, "C3", f"{result['states']} states per {unit}, spread over k "
           "episodes")):
        if not ks:
          continue
        ys = np.array([[row[0] for row in v[reading_key(name, k, m)]] for k in ks])  # [k, seeds]
        for seed in range(ys.shape[1]):
          ax.plot(ks, ys[:, seed], color=color, ls=style, alpha=0.2, lw=0.8)
        ax.plot(ks, ys.mean(1), color=color, ls=style, lw=2.2, marker=marker,
                label=of + text + ", mean of seeds")
    for k, name, style in ((QUICK, "quick protocol", ":"), (FINAL, "final protocol", "--")):
      if min(sizes) <= k <= max(sizes):
        what = f"{k} episodes per skill" if unit == "skill" else f"{k} latents x {k} episodes"
        ax.axvline(k, color="k", ls=style, lw=1, label=f"{name}: {what}")
        if k in counts:   # a continuous prior's protocol reads k latents: its point, starred
          y = np.mean([row[0] for row in v[reading_key(every, k, k)]])
          ax.plot([k], [y], "k*", ms=13, zorder=5,
                  label="the protocols' readings" if k == QUICK or QUICK not in counts else None)
    ax.set_xscale("log")
    ax.set_xticks(sizes, [str(k) for k in sizes])
    ax.minorticks_off()
    ax.set_xlabel(f"episodes per {unit} read together (k)")
    ax.set_ylabel(f"{label} of {result['feature']}, nats")
    ax.grid(alpha=0.3)
  axes[0].legend(fontsize=7, loc="best")
  actions = "mean" if result["deterministic"] else "sampled"
  pooled = (f"k of {result['pool']} pooled episodes per skill" if unit == "skill" else
            f"m of {result['pool']} pooled latents, k of {result['pool']} episodes of each")
  fig.suptitle(plots.fit_title(
      f"{result['label']}, checkpoint at {result['env_steps'] / 1e6:.1f} M env steps\nthe paper's "
      f"MI estimator on {pooled} ({actions} actions; each point the mean of {result['draws']} "
      "draws)", fig), fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=120)
  plt.close(fig)
  return path


def _check_run(run: runs.Run, parser) -> bool:
  """Whether the run's prior is continuous; ``parser.error`` where it has no skills to read."""
  return common.require_discrete_skills(run, parser, "this analysis draws episodes per skill",
                                        continuous=True)


def _positive_ints(parser, text: str, flag: str) -> list[int]:
  try:
    values = sorted({int(s) for s in text.split(",")})
  except ValueError:
    parser.error(f"{flag} {text!r}: give comma-separated whole numbers, e.g. 1,4,10")
  if values[0] < 1:
    parser.error(f"{flag} {text!r}: every size must be at least 1")
  return values


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  common.add_analysis_arguments(parser, "an MI-max run directory with discrete skills or a "
                                "continuous prior (config.json and checkpoint)")
  parser.add_argument("--pool", type=int, default=None,
                      help="episodes of each skill rolled out per seed (default 20); a "
                           "continuous prior's: latents drawn per seed, and episodes of each")
  parser.add_argument("--sizes", default=None,
                      help="episodes per skill read together, comma-separated, each at most "
                           "--pool (default 1,2,4,10 and the pool)")
  parser.add_argument("--latents", default=None,
                      help="a continuous prior's: latents read together, comma-separated, each at "
                           "least 2 and at most --pool (default 4,10, the protocols')")
  parser.add_argument("--states", type=int, default=None,
                      help="states per skill of the fixed-state reading (default 4 x the scored "
                           "steps, the quick protocol's)")
  parser.add_argument("--draws", type=int, default=None,
                      help="random sets of k episodes per skill read for each k (default 200)")
  parser.add_argument("--plot", action="store_true",
                      help="only draw skill_episode_count.png from the JSON")
  args = parser.parse_args(argv)
  name = ("skill_episode_count_deterministic" if args.deterministic
          else "skill_episode_count")
  out = args.out or os.path.join(args.run, name + ".json")
  if args.plot:
    unused = [flag for flag, v in (("--seeds", args.seeds), ("--pool", args.pool),
                                   ("--sizes", args.sizes), ("--latents", args.latents),
                                   ("--states", args.states),
                                   ("--draws", args.draws)) if v is not None]
    if unused:
      parser.error(f"{', '.join(unused)}: choose the analysis; --plot draws its JSON (--out, "
                   "--deterministic: which one)")
    if not os.path.exists(out):
      parser.error(f"{out}: no result to plot; run the analysis first (without --plot)")
    with open(out) as f:
      result = json.load(f)
    print(f"wrote {plot(result, os.path.join(args.run, name + '.png'))}")
    return 0
  pool = 20 if args.pool is None else args.pool
  draws = 200 if args.draws is None else args.draws
  if pool < 1:
    parser.error(f"--pool {pool}: give at least 1 episode per skill")
  if draws < 1:
    parser.error(f"--draws {draws}: give at least 1")
  sizes = (_positive_ints(parser, args.sizes, "--sizes") if args.sizes is not None
           else sorted({k for k in (1, 2, QUICK, FINAL) if k <= pool} | {pool}))
  if sizes[-1] > pool:
    parser.error(f"--sizes {args.sizes}: {sizes[-1]} is more than the --pool of {pool} "
                 "episodes per skill")
  run, picked = common.load_picked(parser, args.run, args.seeds)
  continuous = _check_run(run, parser)
  latent_counts = None
  if continuous:
    latent_counts = (_positive_ints(parser, args.latents, "--latents") if args.latents is not None
                     else [m for m in (QUICK, FINAL) if m <= pool])
    if not latent_counts or latent_counts[0] < 2 or latent_counts[-1] > pool:
      parser.error(f"--latents {args.latents or 'default'}: each count must be at least 2 (one "
                   f"latent has no MI to read) and at most the --pool of {pool} latents drawn")
  elif args.latents is not None:
    parser.error(f"--latents {args.latents}: {run.spec.objective}'s prior is categorical, whose "
                 "every skill the evaluator reads; --latents is for a continuous prior")
  length = metrics.scored_steps(run.env)
  states = QUICK * length if args.states is None else args.states
  if states < 1:
    parser.error(f"--states {states}: give at least 1 state per skill")
  fixed = fixed_state_sizes(sizes, states, length)
  if not fixed:
    parser.error(f"--states {states}: no size of {sizes} splits it evenly into at most the "
                 f"{length} scored steps of an episode; give a multiple of a size, e.g. "
                 f"{QUICK * length}")
  params, keys = common.picked_seeds(run, picked, 3)
  scale = run.objective.spec.obs_scale

  def one(p, k):
    roll_key, read_key = jax.random.split(k)
    scored = pooled_episodes(run, p, roll_key, pool, deterministic=args.deterministic)
    return readings(scored, read_key, sizes, draws, scale, states, latent_counts)

  values = {k: np.asarray(v).tolist() for k, v in jax.jit(jax.vmap(one))(params, keys).items()}
  result = {"run": os.path.abspath(args.run), "seeds": [run.spec.seeds[p] for p in picked],
            "label": common.run_label(run.spec, directory=run.directory),
            "feature": plots.feature_labels(run.env, metrics.eval_indices(run.objective)[:1])[0],
            "deterministic": args.deterministic, "pool": pool, "sizes": sizes,
            "fixed_state_sizes": fixed, "states": states, "scored_steps": length,
            "draws": draws, "env_steps": run.env_steps, "prior": run.objective.spec.prior.kind,
            "latent_counts": latent_counts, "per_seed": values}
  if not continuous:
    result.update(num_skills=run.objective.spec.prior.dim,
                  ln_num_skills=math.log(run.objective.spec.prior.dim))
  common.write_json(out, result)
  actions = "mean" if args.deterministic else "sampled"
  pooled = (f"{pool} latents x {pool} episodes" if continuous
            else f"{pool} episodes per skill") + " pooled"
  print(f"{run.spec.objective} on {run.spec.env}, seeds {result['seeds']}, {actions} actions, "
        f"{pooled}, {draws} draws")
  print(common.seed_table({k: v for k, v in values.items() if "_std/" not in k},
                          "reading/k (per observed dimension)"))
  print(f"wrote {out}")
  return 0


if __name__ == "__main__":
  sys.exit(main())
