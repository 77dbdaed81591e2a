"""Which way, and how fast, a run's policy moves its body (#15). A run rewarded on the root's
velocity (``ant_run``, ``pro_ant_run``: r = 5 - ||v_xy - (4, 0)||) scores how far its velocity is
from the target, not whether the agent runs slowly toward it or fast the wrong way; nor which way,
in its own frame, the body runs (along a leg or between two).

    python benchmarks/root_velocity.py RUN_DIR [--seeds 0,1] [--episodes 4] [--latents 8]
                                               [--deterministic] [--out FILE.json]

Per seed, ``--episodes`` episodes rolled out as the evaluator does (the env's length, actions
sampled unless ``--deterministic``, no reset after a fall), read over the scored window (the last
``metrics.scored_steps`` steps), every step of every episode pooled. A policy that takes a latent
(an MI-max run's skills) runs ``--episodes`` episodes under each of the evaluator's latents
(``metrics.latents_for_evaluation``: every skill of a categorical prior, ``--latents`` draws of a
continuous one), pooled alike: the skills' gait read together (speed, the direction in the body's
frame, ``upside_down``), while the world velocity averages over skills that run different ways.
- ``velocity``: the mean of the root's xy velocity (world frame, m/s; the env's ``vel_xy``);
- ``speed``: the mean of its norm, and ``steadiness``: ``|mean velocity| / speed`` (1 when every
  step moves the same way);
- ``reward``: the mean env reward per step;
- ``body_velocity``: the mean velocity in the root body's own frame, turned by the body's heading
  (its x axis in the plane); ``body_direction_deg``: its angle from the body's +x (the pro_ant's
  first leg points along +x, the others every 360/N degrees);
- ``heading_deg``: the circular mean of the body's heading in the world (0 where its x axis points
  along the world's +x);
- ``upside_down``: the share of states with the root's up axis below the horizon.
``summary`` holds the mean and std over seeds of each; the circular ones are averaged as angles.
The JSON also names the run's env, its PPO settings over its row's (``ppo``) and the env steps per
seed its checkpoint had trained (``env_steps``: an unfinished run's last checkpoint's).
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import jax
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import metrics  # noqa: E402

ANGLES = ("body_direction_deg", "heading_deg")
LATENTS = common.POLICY_LATENTS  # --latents' default, the analyses' own


def episodes(run, params, key: jax.Array, num: int, deterministic: bool,
             num_latents: int = LATENTS):
  """``(velocity [E, T, 2], x_axis [E, T, 2], up [E, T], reward [E, T])`` over the scored window
  of one seed's ``params``: the root's xy velocity, its body x axis in the world's xy plane, the z
  component of its up axis, and the env reward; E = ``num`` episodes, or ``num`` under each of the
  evaluator's latents (``num_latents`` draws of a continuous prior) where the policy takes one."""
  indices = np.asarray(run.env.obs_indices("vel_xy"))
  last = metrics.scored_steps(run.env)
  latents, conditioned = common.policy_latents(run, jax.random.fold_in(key, 1), num_latents)
  out = metrics.rollout(
      run.env, run.policy, params, latents, key, episodes_per_latent=num,
      conditions_policy=conditioned, deterministic=deterministic,
      record=lambda s, a, n: (n.obs[..., indices], n.data.xmat[..., 1, :2, 0],
                              n.data.xmat[..., 1, 2, 2], n.reward))
  return tuple(x.reshape((-1,) + x.shape[2:])[:, -last:] for x in out)


def read_seed(velocity, x_axis, up, reward) -> dict:
  """One seed's figures (the module's doc) from ``episodes``' arrays."""
  v = np.asarray(velocity, np.float64).reshape(-1, 2)
  x = np.asarray(x_axis, np.float64).reshape(-1, 2)
  yaw = np.arctan2(x[:, 1], x[:, 0])
  c, s = np.cos(yaw), np.sin(yaw)
  body = np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]], axis=1)
  mean_v, mean_body = v.mean(0), body.mean(0)
  speed = float(np.linalg.norm(v, axis=1).mean())
  return {"velocity": mean_v.tolist(), "speed": speed,
          "steadiness": float(np.linalg.norm(mean_v) / speed) if speed > 0 else 0.0,
          "reward": float(np.mean(reward)),
          "body_velocity": mean_body.tolist(),
          "body_direction_deg": math.degrees(math.atan2(mean_body[1], mean_body[0])),
          "heading_deg": math.degrees(math.atan2(s.mean(), c.mean())),
          "upside_down": float((np.asarray(up) < 0).mean())}


def summary(seeds: list[dict]) -> dict:
  """Mean and std over seeds of each figure of ``read_seed``; angles by their circular mean and
  circular std (sqrt(-2 ln R), in degrees)."""
  out = {}
  for name in seeds[0]:
    values = np.asarray([seed[name] for seed in seeds], np.float64)
    if name in ANGLES:
      rad = np.radians(values)
      r = math.hypot(np.cos(rad).mean(), np.sin(rad).mean())
      out[name] = {"mean": math.degrees(math.atan2(np.sin(rad).mean(), np.cos(rad).mean())),
                   "std": math.degrees(math.sqrt(-2 * math.log(r))) if r > 0 else float("inf")}
    else:
      out[name] = {"mean": values.mean(0).tolist(), "std": values.std(0).tolist()}
  return out


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  common.add_analysis_arguments(parser, "a trained run directory of an env whose root moves in the "
                                "plane (ant_run, pro_ant_run, an Ant MI-max row, ...)")
  parser.add_argument("--episodes", type=int, default=4,
                      help="episodes per seed, or per latent of a policy that takes one "
                      "(default 4)")
  parser.add_argument("--latents", type=int, default=None,
                      help="a policy that takes a latent from a continuous prior: how many of the "
                      f"prior's draws it runs under (default {LATENTS}; a categorical prior runs "
                      "every skill)")
  parser.add_argument("--key-seed", type=int, default=0, help="PRNG seed of the episodes")
  args = parser.parse_args()
  if args.episodes < 1:
    parser.error(f"--episodes {args.episodes}: give 1 or more")
  if args.latents is not None and args.latents < 1:
    parser.error(f"--latents {args.latents}: give 1 or more")
  run, picked = common.load_picked(parser, args.run, args.seeds)
  takes_latent = run.objective.conditions_policy
  if args.latents is not None and not (takes_latent and metrics.draws_latents(run.objective)):
    parser.error(f"--latents {args.latents}: {args.run}'s policy "
                 + ("runs every skill of its categorical prior (or its one latent)"
                    if takes_latent else f"takes no latent (objective {run.spec.objective!r})")
                 + "; --latents counts the draws of a continuous prior")
  if "vel_xy" not in run.env.named_indices:
    parser.error(f"{args.run}: env {run.spec.env!r} has no root xy velocity in its observation "
                 f"(its named sets: {', '.join(sorted(run.env.named_indices))}); "
                 "root_velocity.py reads bodies that move in the plane")
  params, keys = common.picked_seeds(run, picked, args.key_seed)
  arrays = jax.jit(jax.vmap(lambda p, k: episodes(run, p, k, args.episodes, args.deterministic,
                                                  args.latents or LATENTS)))(params, keys)
  arrays = [np.asarray(a) for a in arrays]
  # the PPO settings it trained with over its row's (e.g. an entropy_cost), so that a reader of the
  # JSON, or gait_search.py --plot-legs, tells runs of one env apart
  # and how far it had trained: an unfinished run's policy is its last checkpoint's, which, where
  # it trained in segments (train(checkpoint_segments=...)), may be past its last evaluation
  result = {"run": args.run, "env": run.spec.env, "env_params": run.spec.env_params or {},
            "ppo": dict(run.spec.ppo or {}), "env_steps": run.env_steps,
            "episodes": args.episodes,
            "latents": int(arrays[0].shape[1] // args.episodes) if takes_latent else None,
            "deterministic": args.deterministic, "per_seed": {}}
  for i, position in enumerate(picked):
    seed = run.spec.seeds[position]
    read = read_seed(*(a[i] for a in arrays))
    result["per_seed"][str(seed)] = read
    print(f"seed {seed}: velocity ({read['velocity'][0]:.2f}, {read['velocity'][1]:.2f}) m/s, "
          f"speed {read['speed']:.2f}, reward {read['reward']:.2f}, body direction "
          f"{read['body_direction_deg']:.0f} deg, heading {read['heading_deg']:.0f} deg",
          flush=True)
  result["summary"] = summary(list(result["per_seed"].values()))
  for name, row in result["summary"].items():
    print(f"{name}: {row}")
  out = args.out or os.path.join(args.run, "root_velocity" + (
      "_deterministic" if args.deterministic else "") + ".json")
  common.write_json(out, result)
  print(f"wrote {out}")


if __name__ == "__main__":
  main()
