"""Where an MI-max row's latent goal reaching (LGR) goes (#15): the goals its policy cannot reach
under any latent, against the goals it could reach under a latent other than the one inferred.

    python benchmarks/goal_reaching.py RUN_DIR [--seeds 0,1] [--episodes 4] [--candidates 24]
                                               [--goal-draw braxlines|partitionable]
                                               [--deterministic] [--out FILE.json]
    python benchmarks/goal_reaching.py RUN_DIR --plot [--out FILE.png]   # from goal_reaching.json

The paper's LGR (Algorithm 2) draws goals g ~ U(-obs_scale, obs_scale)^D (10, seed 0), infers a
latent for each (the mean of q(z|g), or the most likely skill), rolls the policy out under it and
scores ``mean_t sqrt(mean_d (s_d - g_d)^2)`` over the last scored steps. A high LGR has two
causes: goals beyond every speed (or place) the policy reaches, and an inferred latent that is not
the policy's best for its goal. This script tells them apart.

Per seed, on the protocol's goals (``metrics.lgr_goals``: by default the paper's, ``--goal-draw
partitionable`` for those blx drew before session 41) and the latents it infers
(``metrics.infer_goal_latents``), ``--episodes`` episodes each, and on ``--candidates`` latents of
the prior (every skill's one-hot for discrete skills, prior draws otherwise), the same number of
episodes each, actions sampled unless ``--deterministic``:
- ``lgr``: the LGR of the inferred latents' episodes (the protocol's metric, on fewer episodes);
- ``best_lgr``: for each goal, the lowest LGR of any candidate latent's episodes, averaged over
  goals: what the policy scores where the inference picks its best latent;
- ``reach_lgr``: for each goal, its distance to the nearest candidate's mean state, averaged over
  goals: what a policy that sat at that mean would score. For continuous latents it is near zero
  for a goal between the lowest and highest mean, so it counts the goals beyond the policy's reach
  (discrete skills also count a goal's distance to the nearer of two neighbouring skills);
- ``inference_excess`` = ``lgr - best_lgr``: the part of the LGR the inferred latents add;
- ``reach_low``, ``reach_high``: the lowest and highest candidate mean state, per dimension;
- ``spread_within``, ``spread_between``: how widely one latent's states spread, split into the
  part within episodes (the root of the mean of each episode's variance over its steps: a gait's
  swing) and the part between them (the std of the episodes' means), averaged over the
  candidates; their squares add up to the variance of the latent's states. The histogram MI
  (``metrics.particle``) pays for either;
- where the latents are goals (GCRL: an identity posterior over the evaluated dimensions), how
  the skills follow them, from each candidate's goal z and mean state m: ``farthest``, the largest
  |m| (for velocity goals, the top speed); ``goal_share``, the median over candidates of |m| / |z|
  (the share of its goal's distance a skill covers); ``goal_cosine``, the mean of the cosine
  between z and m (1: every skill goes its goal's way); and ``reached_norm``, the mean |m| the
  inferred latents reach on the protocol's goals;
- per goal (``goals``, ``inferred_latents``, ``reached_mean``, ``reached_std`` over the episodes'
  states, ``goal_lgr``, ``goal_best_lgr``, ``goal_reach``), and per candidate (``candidates``,
  ``candidate_means``, ``candidate_within_std``, ``candidate_between_std``).

Prints the mean +- std over seeds; writes every per-seed value to ``--out`` (default
RUN_DIR/goal_reaching.json). ``--plot`` draws every seed's goals against what they reached, and
the candidates' mean states, from that JSON (default RUN_DIR/goal_reaching.png).
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import metrics  # noqa: E402
from blx.experiments import plots  # noqa: E402
from blx.objectives.specs import MimaxSpec  # noqa: E402


def distances(states: jax.Array, goals: jax.Array) -> jax.Array:
  """``mean_{m,t} sqrt(mean_d (s - g)^2)`` of every latent's states ``[L, M, T, D]`` to every goal
  ``[G, D]``: ``[G, L]`` (Algorithm 2's distance, one latent's episodes at a time)."""
  diff = states[None] - goals[:, None, None, None, :]  # [G, L, M, T, D]
  return jnp.sqrt(jnp.mean(diff**2, -1)).mean((2, 3))


def decompose(reached: jax.Array, goals: jax.Array, candidates: jax.Array) -> dict:
  """The decomposition of the module's doc, from the feature states of the goals' episodes
  ``reached [G, M, T, D]`` (episode g under goal g's inferred latent) and of the candidates'
  ``candidates [C, M, T, D]``."""
  own = jnp.sqrt(jnp.mean((reached - goals[:, None, None]) ** 2, -1)).mean((1, 2))  # [G]
  against = distances(candidates, goals)  # [G, C]
  means = candidates.mean((1, 2))  # [C, D]
  reach = jnp.sqrt(jnp.mean((means[None] - goals[:, None]) ** 2, -1)).min(1)  # [G]
  best = against.min(1)
  return {"lgr": own.mean(), "best_lgr": best.mean(), "reach_lgr": reach.mean(),
          "inference_excess": own.mean() - best.mean(),
          "reach_low": means.min(0), "reach_high": means.max(0),
          "reached_mean": reached.mean((1, 2)), "reached_std": reached.std((1, 2)),
          "goal_lgr": own, "goal_best_lgr": best, "best_candidate": against.argmin(1),
          "goal_reach": reach, "candidate_means": means,
          **{f"candidate_{k}": v for k, v in spread(candidates).items()}}


def spread(states: jax.Array) -> dict:
  """How widely each latent's states ``[L, M, T, D]`` (M episodes of T scored steps) spread, split
  by the law of total variance into ``within_std`` (the root of the mean over episodes of each
  episode's variance over its steps: a gait's swing, or drift within an episode) and
  ``between_std`` (the std of the episodes' means: each episode at its own place or speed);
  ``within_std**2 + between_std**2`` is the variance of all M x T states. Each ``[L, D]``."""
  return {"within_std": jnp.sqrt(states.var(2).mean(1)),
          "between_std": states.mean(2).std(1)}


def seed_goals(run, params, key: jax.Array, goals: jax.Array, episodes: int,
               num_candidates: int, deterministic: bool) -> dict:
  """One seed's episodes under the latents inferred for ``goals`` ``[G, D]``
  (``metrics.lgr_goals``) and under the candidate latents, and ``decompose`` of them, with the
  goals and the latents."""
  objective = run.objective
  indices = np.asarray(metrics.eval_indices(objective))
  inferred = metrics.infer_goal_latents(run.env, objective, params.objective, goals)
  z_key, roll_key = jax.random.split(key)
  candidates = metrics.latents_for_evaluation(objective, z_key, num_candidates)
  last = metrics.scored_steps(run.env)
  states = metrics.rollout(run.env, run.policy, params,
                           jnp.concatenate([inferred, candidates]), roll_key,
                           episodes_per_latent=episodes, deterministic=deterministic,
                           record=lambda state, action, next_state: next_state.obs[..., indices])
  states = states[:, :, -last:]  # [G + C, M, T, D]
  g = goals.shape[0]
  out = decompose(states[:g], goals, states[g:])
  out.update(goals=goals, inferred_latents=inferred, candidates=candidates)
  return out


def following(goals: np.ndarray, means: np.ndarray, reached: np.ndarray) -> dict:
  """How skills whose latents are goals follow them: from each candidate's goal ``goals [..., C,
  D]`` and mean state ``means [..., C, D]``, and the mean states the inferred latents reached on
  the protocol's goals ``reached [..., G, D]``, the ``FOLLOWING`` values of the module's doc (each
  ``[...]``). A candidate at the origin (no direction) has share and cosine 0."""
  goal_norm = np.linalg.norm(goals, axis=-1)
  mean_norm = np.linalg.norm(means, axis=-1)
  share = np.divide(mean_norm, goal_norm, out=np.zeros_like(mean_norm), where=goal_norm > 0)
  both = goal_norm * mean_norm
  cosine = np.divide((goals * means).sum(-1), both, out=np.zeros_like(both), where=both > 0)
  return {"farthest": mean_norm.max(-1), "goal_share": np.median(share, -1),
          "goal_cosine": cosine.mean(-1),
          "reached_norm": np.linalg.norm(reached, axis=-1).mean(-1)}


def latents_are_goals(spec: MimaxSpec) -> bool:
  """Whether a latent is a goal in the evaluated feature space (GCRL's identity posterior over the
  dimensions evaluation looks at), so that ``following`` means something."""
  return spec.posterior == "identity" and tuple(spec.obs_indices or ()) == tuple(
      spec.eval_indices or spec.obs_indices or ())


DECOMPOSED = ("lgr", "best_lgr", "reach_lgr", "inference_excess", "reach_low", "reach_high")
FOLLOWING = ("farthest", "goal_share", "goal_cosine", "reached_norm")
SUMMARY = DECOMPOSED + ("spread_within", "spread_between")


def summary_values(values: dict, latent_goals: bool = False) -> dict:
  """The ``SUMMARY`` values per seed from ``seed_goals``' (vmapped over seeds): the spreads are the
  candidates' mean ``within_std`` and ``between_std``; with ``latent_goals`` (GCRL), also the
  ``FOLLOWING`` values."""
  out = {**{k: values[k] for k in DECOMPOSED},
         "spread_within": values["candidate_within_std"].mean(-2),
         "spread_between": values["candidate_between_std"].mean(-2)}
  if latent_goals:
    out.update(following(*(np.asarray(values[k]) for k in
                           ("candidates", "candidate_means", "reached_mean"))))
  return out


def plot(result: dict, path: str) -> str:
  """Every seed's goals against the mean state their inferred latent reached (first dimension),
  with the candidates' range, beside each candidate's mean state against its latent (first
  dimensions; discrete skills: against the skill's rank)."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt

  seeds = result["per_seed"]
  fig, (left, right) = plt.subplots(1, 2, figsize=(12, 6))
  colours = plt.cm.tab10(np.linspace(0, 1, 10))
  scale = result["obs_scale"]
  for i, (seed, row) in enumerate(seeds.items()):
    c = colours[i % 10]
    goals = np.asarray(row["goals"])[:, 0]
    reached = np.asarray(row["reached_mean"])[:, 0]
    left.errorbar(goals, reached, yerr=np.asarray(row["reached_std"])[:, 0], fmt="o", ms=4,
                  color=c, alpha=0.7, capsize=2, label=f"seed {seed}")
    means = np.asarray(row["candidate_means"])[:, 0]
    if result["discrete"]:
      right.plot(np.arange(len(means)), np.sort(means), "o-", color=c, ms=4, alpha=0.8)
    else:
      z = np.asarray(row["candidates"])[:, 0]
      order = np.argsort(z)
      right.plot(z[order], means[order], "o-", color=c, ms=3, alpha=0.8)
  low = np.mean([np.asarray(r["reach_low"])[0] for r in seeds.values()])
  high = np.mean([np.asarray(r["reach_high"])[0] for r in seeds.values()])
  left.axhspan(low, high, color="0.85", zorder=0,
               label="the candidates' mean states, lowest to highest (mean over seeds)")
  left.plot([-scale, scale], [-scale, scale], "k--", lw=1, label="reached = goal")
  left.set_xlim(-scale * 1.05, scale * 1.05)
  left.set_xlabel(f"goal (obs index {result['indices'][0]})")
  left.set_ylabel("mean state reached under the inferred latent (± std of its states)")
  left.set_title("the protocol's goals: what the inferred latent reached", fontsize=10)
  left.legend(handles=left.get_legend_handles_labels()[0][:2], fontsize=7, loc="upper left")
  fig.legend(*[x[2:] for x in left.get_legend_handles_labels()], fontsize=8, loc="lower center",
             ncol=min(len(seeds), 10), title="one colour per seed, in both panels",
             title_fontsize=8)
  right.axhline(0, color="0.6", lw=0.8)
  right.set_ylabel(f"candidate's mean state (obs index {result['indices'][0]})")
  if result["discrete"]:
    right.set_xlabel("skill, sorted by its mean state")
    right.set_title("each skill's mean state, one line per seed", fontsize=10)
  else:
    right.set_xlabel("candidate latent (first dimension)")
    right.set_title("each prior latent's mean state, one line per seed", fontsize=10)
  s = result["summary"]
  actions = "mean" if result["deterministic"] else "sampled"
  # a JSON written before session 41 has no goal_draw: its goals were the partitionable draw
  goals = {"braxlines": "the paper's goals", "partitionable": "goals of the partitionable draw"}[
      result.get("goal_draw", "partitionable")]
  fig.suptitle(plots.fit_title(
      f"{result['label']}, {actions} actions, {goals}\nLGR {s['lgr'][0]:.2f}; with each goal's "
      f"best latent {s['best_lgr'][0]:.2f}; sitting at the mean state nearest each goal "
      f"{s['reach_lgr'][0]:.2f} (lower is better; means over seeds)", fig), fontsize=10)
  fig.tight_layout(rect=(0, 0.1, 1, 1))
  fig.savefig(path, dpi=120)
  plt.close(fig)
  return path


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  common.add_analysis_arguments(parser, "an MI-max run directory (config.json and checkpoint)")
  parser.add_argument("--episodes", type=int, default=4,
                      help="episodes per goal and per candidate latent (default 4)")
  parser.add_argument("--candidates", type=int, default=24,
                      help="prior latents tried for a continuous prior (default 24; discrete "
                      "skills try every skill)")
  parser.add_argument("--goal-draw", choices=metrics.LGR_GOAL_DRAWS, default=None,
                      help="the protocol's goals: braxlines (default), the paper's, drawn with "
                      "the random bits of the JAX it ran on; partitionable, those blx's "
                      "evaluators drew before session 41 (metrics.lgr_goals)")
  parser.add_argument("--plot", action="store_true",
                      help="only draw goal_reaching.png from RUN_DIR/goal_reaching.json")
  args = parser.parse_args(argv)
  default_json = os.path.join(args.run, "goal_reaching.json")
  if args.plot:
    if args.seeds is not None or args.deterministic or args.goal_draw is not None:
      parser.error("--seeds, --deterministic and --goal-draw choose the analysis; --plot draws "
                   "its JSON")
    if not os.path.exists(default_json):
      parser.error(f"--plot: {default_json} is missing; run the analysis first")
    with open(default_json) as f:
      result = json.load(f)
    print(f"wrote {plot(result, args.out or os.path.join(args.run, 'goal_reaching.png'))}")
    return 0
  if args.episodes < 1:
    parser.error(f"--episodes {args.episodes}: give 1 or more")
  if args.candidates < 1:
    parser.error(f"--candidates {args.candidates}: give 1 or more")
  run, picked = common.load_picked(parser, args.run, args.seeds)
  if not isinstance(run.objective.spec, MimaxSpec):
    parser.error(f"{args.run}: objective {run.spec.objective!r} is not MI-max; goal reaching "
                 "needs latents (gcrl, cdiayn, diayn, diayn_full)")
  params, keys = common.picked_seeds(run, picked, 2)
  draw = args.goal_draw or metrics.LGR_GOAL_DRAWS[0]
  goals = metrics.lgr_goals(run.objective, draw=draw)
  values = jax.jit(jax.vmap(lambda p, k: seed_goals(
      run, p, k, goals, args.episodes, args.candidates, args.deterministic)))(params, keys)
  values = {k: np.asarray(v) for k, v in values.items()}
  summary = summary_values(values, latents_are_goals(run.objective.spec))
  prior = run.objective.spec.prior
  result = {"run": os.path.abspath(args.run),
            "label": common.run_label(run.spec, directory=run.directory),
            "indices": [int(i) for i in metrics.eval_indices(run.objective)],
            "obs_scale": float(run.objective.spec.obs_scale),
            "discrete": prior.kind == "categorical", "episodes": args.episodes,
            "goal_draw": draw,
            "deterministic": args.deterministic,
            "summary": {k: np.atleast_1d(v.mean(0)).tolist() for k, v in summary.items()},
            "per_seed": {str(run.spec.seeds[p]): {k: v[i].tolist() for k, v in values.items()}
                         for i, p in enumerate(picked)}}
  out = args.out or default_json
  common.write_json(out, result)
  actions = "mean" if args.deterministic else "sampled"
  print(f"{result['label']}, seeds {[run.spec.seeds[p] for p in picked]}, {actions} actions, "
        f"{args.episodes} episodes per goal and per candidate")
  print(common.seed_table(summary))
  print(f"wrote {out}")
  return 0


if __name__ == "__main__":
  sys.exit(main())
