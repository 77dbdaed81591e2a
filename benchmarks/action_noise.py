"""How much noise a trained policy's evaluation actions carry about their mean (#15).

    python benchmarks/action_noise.py RUN_DIR [--seeds 0,1] [--episodes 2] [--samples 64]
                                              [--out FILE.json]

The paper's H(s) scores the states of episodes whose actions are sampled, so a policy that holds
still scores what its action noise shakes out of the body. ``noise_entropy.py`` measures H(s) of a
body under pure noise ``clip(sigma * N(0, I), -1, 1)``, whose action std is about sigma for small
sigma; this script measures the same std for a trained policy, at the states it visits.

Per seed: ``--episodes`` evaluation episodes per latent (MI-max: every skill's one-hot, or 8 of
the prior's latents; D-min and the rest: episodes without a latent), actions sampled; at every
50th state of the scored window (the last ``metrics.scored_steps`` states), ``--samples`` actions
are sampled anew. ``action_std``: their std at each state (the action the env gets, after the
policy's squashing), averaged over action dims and states; ``mean_abs_action``: the mean |action|;
``saturated_share``: the share of sampled actions beyond 0.99 in magnitude; ``action_std_by_joint``:
the std of each action over the states, named by the joint it drives (which joints the policy
shakes most). It also prints that per joint, as mean +- std over seeds.
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

EVERY = 50  # one state in EVERY of the scored window


def noise_at(policy, params, obs: jax.Array, z: jax.Array | None, key: jax.Array,
             samples: int) -> dict:
  """At each state of ``obs [N, O]`` (with latents ``z [N, Z]`` or None), ``samples`` actions
  drawn from ``policy(params, obs, z, key=, deterministic=False)``: the std over the draws
  (averaged over action dims) ``[N]`` and per action dim ``[N, A]``, the mean |action| ``[N]`` and
  the share of draws beyond 0.99 in magnitude ``[N]``."""
  draws = jax.vmap(lambda k: policy(params, obs, z, key=k, deterministic=False))(
      jax.random.split(key, samples))  # [samples, N, A]
  return {"action_std": draws.std(0).mean(-1), "action_std_by_action": draws.std(0),
          "mean_abs_action": jnp.abs(draws).mean((0, 2)),
          "saturated_share": (jnp.abs(draws) > 0.99).mean((0, 2))}


def seed_noise(run, params, key: jax.Array, episodes: int, samples: int) -> dict:
  """``noise_at``'s means over the states of one seed's evaluation episodes (the module's doc)."""
  latents, mimax = common.policy_latents(run, key)
  last = metrics.scored_steps(run.env)
  obs = metrics.rollout(run.env, run.policy, params, latents, key, episodes_per_latent=episodes,
                        conditions_policy=mimax)  # [L, M, T, O]
  states = obs[:, :, -last::EVERY]  # [L, M, S, O]
  # each state's latent, in the order of the states' rows below: latent l for its M x S states
  z = jnp.repeat(latents, states.shape[1] * states.shape[2], axis=0) if mimax else None
  out = noise_at(run.policy, params, states.reshape(-1, states.shape[-1]), z,
                 jax.random.fold_in(key, 1), samples)
  return {k: v.mean(0) if k == "action_std_by_action" else v.mean() for k, v in out.items()}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("run", help="a trained run directory")
  parser.add_argument("--seeds", default=None,
                      help="comma-separated positions in the run's seeds (default all)")
  parser.add_argument("--episodes", type=int, default=2,
                      help="evaluation episodes per latent and seed (default 2)")
  parser.add_argument("--samples", type=int, default=64,
                      help="actions drawn at each state (default 64)")
  parser.add_argument("--key-seed", type=int, default=0, help="PRNG seed of the episodes")
  parser.add_argument("--out", default=None,
                      help="the JSON file to write (default RUN_DIR/action_noise.json)")
  args = parser.parse_args()
  if args.episodes < 1:
    parser.error(f"--episodes {args.episodes}: give 1 or more")
  if args.samples < 2:
    parser.error(f"--samples {args.samples}: give 2 or more (a std needs two draws)")
  run, picked = common.load_picked(parser, args.run, args.seeds)
  params, keys = common.picked_seeds(run, picked, args.key_seed)
  values = jax.jit(jax.vmap(lambda p, k: seed_noise(run, p, k, args.episodes, args.samples)))(
      params, keys)
  by_action = np.asarray(values.pop("action_std_by_action"), np.float64)  # [seeds, A]
  names = common.action_names(run.env)
  result = {"run": args.run, "episodes": args.episodes, "samples": args.samples, "per_seed": {}}
  for i, position in enumerate(picked):
    row = {k: float(v[i]) for k, v in values.items()}
    print(f"seed {run.spec.seeds[position]}: " + ", ".join(f"{k} {v:.3f}" for k, v in row.items()))
    row["action_std_by_joint"] = dict(zip(names, by_action[i].tolist()))
    result["per_seed"][str(run.spec.seeds[position])] = row
  print("| joint | action std, mean +- std over seeds |\n| --- | ---: |")
  for j, name in enumerate(names):
    print(f"| {name} | {by_action[:, j].mean():.3f} +- {by_action[:, j].std():.3f} |")
  for key in values:
    v = np.asarray(values[key], np.float64)
    print(f"{key}: {v.mean():.3f} +- {v.std():.3f} over seeds ({v.min():.3f} to {v.max():.3f})")
  out = args.out or os.path.join(args.run, "action_noise.json")
  common.write_json(out, result)
  print(f"wrote {out}")


if __name__ == "__main__":
  main()
