"""How a D-min run's body reaches the target's modes: upright, or on its back (#15).

    python benchmarks/posture.py RUN_DIR [--seeds 0,1] [--episodes 10] [--deterministic]
                                         [--out FILE.json]

Per seed, ``--episodes`` episodes rolled out as the evaluator does (the env's length, actions
sampled unless ``--deterministic``, no reset after a fall), read over the scored window (the last
``metrics.scored_steps`` states):
- per episode, ``upside_down``: the share of the window's states in which the root body (the env's
  first body, the torso) has its up axis below the horizon (``data.xmat``'s z-z entry below 0); the
  episode counts as on its back where that share is over a half. ``feature``: the mean of each
  matched feature (e.g. the x velocity), ``feature_std``: its std within the episode, and
  ``mode_share``: the share of the window's states nearest each of the target's modes;
- over the seeds (``summary``), per posture (upright, on its back): the number of episodes, and
  the mean over them of ``feature``, ``feature_std`` and ``mode_share``.
A body on its back whose matched feature swings both ways within an episode meets a target of two
modes on that feature without running either way, and the energy distance, which scores the
feature alone, cannot tell.
"""

from __future__ import annotations

import argparse
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import metrics  # noqa: E402
from blx.experiments import runs  # noqa: E402
from blx.objectives.specs import DminSpec  # noqa: E402

POSTURES = ("upright", "on its back")


def episodes(run, params, key: jax.Array, num: int, deterministic: bool):
  """``(feature [num, T, D], up [num, T])`` over the scored window of ``num`` episodes of one
  seed's ``params``: the matched features and the z component of the root body's up axis."""
  indices = np.asarray(run.objective.spec.obs_indices)
  last = metrics.scored_steps(run.env)
  feature, up = metrics.rollout(
      run.env, run.policy, params, jnp.zeros((1, 0)), key, episodes_per_latent=num,
      conditions_policy=False, deterministic=deterministic,
      record=lambda s, a, n: (n.obs[..., indices], n.data.xmat[..., 1, 2, 2]))
  return feature[0, :, -last:], up[0, :, -last:]


def per_episode(feature: np.ndarray, up: np.ndarray, means: np.ndarray | None) -> list[dict]:
  """Each episode's posture and feature (the module's doc), from ``episodes``' arrays;
  ``means [K, D]``: the target's modes, or None for a target without them."""
  out = []
  for f, u in zip(np.asarray(feature, np.float64), np.asarray(up, np.float64)):
    episode = {"upside_down": float((u < 0).mean()),
               "feature": f.mean(0).tolist(), "feature_std": f.std(0).tolist()}
    if means is not None:
      nearest = np.argmin(((f[:, None, :] - means[None]) ** 2).sum(-1), axis=1)
      episode["mode_share"] = (np.bincount(nearest, minlength=len(means)) / len(f)).tolist()
    out.append(episode)
  return out


def summary(episodes_of_seeds: list[list[dict]]) -> dict:
  """Per posture: how many episodes, and the mean over them of each per-episode list."""
  out = {}
  flat = [e for seed in episodes_of_seeds for e in seed]
  for posture in POSTURES:
    chosen = [e for e in flat if (e["upside_down"] > 0.5) == (posture == "on its back")]
    row = {"episodes": len(chosen)}
    for key in ("feature", "feature_std", "mode_share"):
      if chosen and key in chosen[0]:
        row[key] = np.mean([e[key] for e in chosen], axis=0).tolist()
    out[posture] = row
  return out


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  common.add_analysis_arguments(parser, "a trained D-min run directory (GAIL, AIRL, ...)")
  parser.add_argument("--episodes", type=int, default=10, help="episodes per seed (default 10)")
  parser.add_argument("--key-seed", type=int, default=0, help="PRNG seed of the episodes")
  args = parser.parse_args()
  if args.episodes < 1:
    parser.error(f"--episodes {args.episodes}: give 1 or more")
  try:
    run = runs.load_run(args.run)
  except runs.RunError as e:
    parser.error(str(e))
  if not isinstance(run.objective.spec, DminSpec):
    parser.error(f"{args.run}: {run.spec.objective} is not a D-min objective (it has no target); "
                 "posture.py reads GAIL, GAIL2, AIRL, FAIRL and MLE runs")
  try:
    picked = common.seed_positions(args.seeds, len(run.spec.seeds))
  except ValueError as e:
    parser.error(str(e))
  params, keys = common.picked_seeds(run, picked, args.key_seed)
  target = run.objective.spec.target
  means = None if target.means is None else np.asarray(target.means, np.float64)
  # every picked seed in one program, as the other analyses: [seeds, episodes, T, ...]
  features, ups = jax.jit(jax.vmap(lambda p, k: episodes(run, p, k, args.episodes,
                                                         args.deterministic)))(params, keys)
  result = {"run": args.run, "episodes": args.episodes, "deterministic": args.deterministic,
            "per_seed": {}}
  for position, feature, up in zip(picked, np.asarray(features), np.asarray(ups)):
    seed = run.spec.seeds[position]
    result["per_seed"][str(seed)] = per_episode(feature, up, means)
    backs = sum(e["upside_down"] > 0.5 for e in result["per_seed"][str(seed)])
    print(f"seed {seed}: {backs} of {args.episodes} episodes on its back", flush=True)
  result["summary"] = summary(list(result["per_seed"].values()))
  for posture, row in result["summary"].items():
    print(f"{posture}: {row}")
  out = args.out or os.path.join(args.run, "posture" + ("_deterministic" if args.deterministic
                                                        else "") + ".json")
  common.write_json(out, result)
  print(f"wrote {out}")


if __name__ == "__main__":
  main()
