"""How much of the ant's H(s) is action noise: H(s) of a policy that only jitters in place.

    python benchmarks/noise_entropy.py [--env ant] [--sigmas 0.7,0.3,0.1,0.03,0.01] [--episodes 8]
                                       [--indices 13,14] [--env-edits JSON]

Each arm runs a policy whose action is ``clip(sigma * N(0, I), -1, 1)`` (no mean, so no skill and
no intent) for whole episodes of the env as registered, with the paper's evaluation protocol for
H(s): the last 500 steps of every episode, the xy velocity (obs 13, 14), the 1-D histogram
entropy with 1000 bins over [-5, 5] averaged over the two dims (``metrics.particle``). It tells what
H(s) a skill that holds still is scored at, as a function of how much action noise its sampled
actions carry: a reading for the DIAYN_FULL row, whose skills are poses (RESULTS, session 8).
Runs on CPU in a few minutes. ``--env-edits`` edits the env's desc as a row's ``--env-edits`` does
(e.g. the HalfCheetah rows' step, ``'{"global_options.timestep": 0.00625,
"global_options.substeps": 8}'``, with ``--indices 11``, the x velocity).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import paper_tables  # noqa: E402

from blx import envs, metrics  # noqa: E402
from blx.metrics import particle  # noqa: E402


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="ant")
  parser.add_argument("--sigmas", default="0.7,0.3,0.1,0.03,0.01")
  parser.add_argument("--episodes", type=int, default=8)
  parser.add_argument("--indices", default="13,14")
  parser.add_argument("--scale", type=float, default=5.0)
  parser.add_argument("--last-steps", type=int, default=500)
  parser.add_argument("--env-edits", default=None, metavar="JSON",
                      help="edits of the env's desc (dotted paths), as paper_tables.py's")
  args = parser.parse_args()
  edits = None
  if args.env_edits:
    try:  # the parsing of paper_tables.py's --env-edits
      edits = paper_tables.json_object(args.env_edits,
                                       'env edits (e.g. {"global_options.substeps": 8})')
    except ValueError as e:
      parser.error(f"--env-edits: {e}")
  try:
    env = envs.create(args.env, **({"edits": edits} if edits else {}))
  except ValueError as e:  # an unknown env, or an edit of a path the env's desc lacks
    parser.error(str(e))
  indices = np.asarray([int(i) for i in args.indices.split(",")])

  def jitter(sigma, obs, z, *, key, deterministic):
    del z, deterministic
    noise = jax.random.normal(key, obs.shape[:-1] + (env.action_size,))
    return jnp.clip(sigma * noise, -1.0, 1.0)

  run = jax.jit(lambda sigma, key: metrics.rollout(
      env, jitter, sigma, jnp.zeros((1, 0)), key, episodes_per_latent=args.episodes,
      conditions_policy=False))
  where = f"{args.env} with {edits}" if edits else args.env
  print(f"env {where}, {args.episodes} episodes per arm, obs {indices.tolist()}, "
        f"H over [-{args.scale}, {args.scale}] with 1000 bins, last {args.last_steps} steps")
  print("| action noise sigma | H(s) | std of velocity (m/s) | episode steps |")
  print("| ---: | ---: | ---: | ---: |")
  for sigma in [float(s) for s in args.sigmas.split(",")]:
    start = time.time()
    obs = run(jnp.float32(sigma), jax.random.PRNGKey(0))  # [1, M, T, O]
    x = obs[0, :, -args.last_steps:][..., indices].reshape(-1, len(indices))
    h = np.mean([float(particle.entropy(x[:, d], bins=1000, value_range=(-args.scale, args.scale)))
                 for d in range(len(indices))])
    print(f"| {sigma:g} | {h:.3f} | {float(jnp.std(x, axis=0).mean()):.3f} | {obs.shape[2]} |"
          f"  ({time.time() - start:.0f} s)", flush=True)


if __name__ == "__main__":
  main()
