"""How long a body stays up from rest under action noise, beside Brax v1's measured reference (#15).

    python benchmarks/body_noise.py [--env humanoid] [--episodes 128] [--steps 400] [--seed 0]
                                    [--sigmas-from ACTION_NOISE_JSON] [--out FILE.json]

Episodes of the env as registered (its reset pose, its torque cut, its termination), vmapped on
whatever device jax has, each until it ends or ``--steps``, under three kinds of action:
- ``zero``: every action 0 (one episode: the reset is deterministic unless the env adds noise);
- ``uniform``: U[-1, 1] on every action, afresh each step (the reference's protocol: Brax v1's 128
  episodes, ``reference/brax-v1-bodies.md`` section 9);
- ``policy_std`` (with ``--sigmas-from``): clip(sigma_j N(0, 1), -1, 1), sigma_j the std of action
  j of a trained policy around its mean (``action_noise.py``'s ``action_std_by_joint``, the mean
  over its seeds): the policy's noise with no policy under it.
Per arm it prints the mean, median and std of the episode lengths (env steps) and the share of
episodes still up at ``--steps``, beside Brax's where the reference has them (the humanoid: zero
actions end at step 41, random ones after 37.8 steps on average; with v0.0.7's rotation fix 57 and
51.9). A body that does not stand unaided falls from rest in any case: the lengths tell how fast
it falls, and how much the noise hastens that, not how much noise a gait that holds it up can take.
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

from blx import envs  # noqa: E402

# Brax v1's measured episode lengths from rest (reference/brax-v1-bodies.md, section 9): the
# paper-time code (v0.0.6) and, in brackets there, the same with the rotation fix (v0.0.7).
BRAX = {"humanoid": {"zero": {"v0.0.6": 41, "rotation fixed": 57},
                     "uniform": {"v0.0.6": 37.8, "rotation fixed": 51.9}}}


def episode_lengths(env, actions_for, key: jax.Array, episodes: int, steps: int) -> np.ndarray:
  """The length of each of ``episodes`` episodes of ``env`` (no auto-reset), stepped with
  ``actions_for(key) -> [A]`` until done or ``steps``: the step at which each ended, or ``steps``
  where none did."""
  def one(k):
    reset_key, act_key = jax.random.split(k)
    state = env.reset(reset_key)

    def body(carry, step_key):
      state, ended = carry
      state = env.step(state, actions_for(step_key))
      return (state, ended | (state.done > 0)), ended | (state.done > 0)

    _, ended = jax.lax.scan(body, (state, jnp.zeros((), bool)), jax.random.split(act_key, steps))
    return jnp.where(ended.any(), jnp.argmax(ended) + 1, steps)

  return np.asarray(jax.jit(jax.vmap(one))(jax.random.split(key, episodes)))


def joint_sigmas(path: str, names: tuple[str, ...]) -> np.ndarray:
  """Each action's std in ``path`` (an action_noise.json), the mean over its seeds, in the order
  of ``names`` (the env's actions). ValueError where the file lacks a joint or is not one."""
  with open(path) as f:
    per_seed = json.load(f).get("per_seed")
  rows = [seed.get("action_std_by_joint") for seed in (per_seed or {}).values()]
  if not rows or any(r is None for r in rows):
    raise ValueError(f"{path} holds no action_std_by_joint per seed (write it with "
                     "action_noise.py RUN_DIR)")
  missing = [n for n in names if n not in rows[0]]
  if missing:
    raise ValueError(f"{path} has no std for {missing}: it was written for another body "
                     f"(its joints: {sorted(rows[0])})")
  return np.array([[r[n] for n in names] for r in rows]).mean(0)


def summary(lengths: np.ndarray, steps: int) -> dict:
  return {"episodes": len(lengths), "mean": float(lengths.mean()),
          "median": float(np.median(lengths)), "std": float(lengths.std()),
          "still_up": float((lengths >= steps).mean())}


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  parser.add_argument("--env", default="humanoid")
  parser.add_argument("--episodes", type=int, default=128)
  parser.add_argument("--steps", type=int, default=400)
  parser.add_argument("--seed", type=int, default=0)
  parser.add_argument("--sigmas-from", default=None, metavar="ACTION_NOISE_JSON",
                      help="an action_noise.py output: adds the policy_std arm")
  parser.add_argument("--out", default=None, help="the JSON file to write (default: none)")
  args = parser.parse_args(argv)
  if args.episodes < 1 or args.steps < 1:
    parser.error(f"--episodes {args.episodes} and --steps {args.steps}: give 1 or more of each")
  try:
    env = envs.create(args.env)
  except ValueError as e:
    parser.error(str(e))
  length = envs.episode_steps(env, "body_noise")
  if args.steps > length:
    parser.error(f"--steps {args.steps}: {args.env}'s episodes end at {length} steps; give at "
                 "most that (a time limit is not a fall)")
  names = common.action_names(env)
  size = env.action_size
  arms = {"zero": (lambda k: jnp.zeros(size), 1),
          "uniform": (lambda k: jax.random.uniform(k, (size,), minval=-1.0, maxval=1.0),
                      args.episodes)}
  sigmas = None
  if args.sigmas_from:
    try:
      sigmas = joint_sigmas(args.sigmas_from, names)
    except (OSError, ValueError) as e:
      parser.error(str(e))
    s = jnp.asarray(sigmas, jnp.float32)
    arms["policy_std"] = (lambda k: jnp.clip(s * jax.random.normal(k, (size,)), -1.0, 1.0),
                          args.episodes)
  key = jax.random.PRNGKey(args.seed)
  result = {"env": args.env, "steps": args.steps, "seed": args.seed, "device": str(jax.devices()[0]),
            "sigmas_from": args.sigmas_from, "arms": {}}
  if sigmas is not None:
    result["sigmas"] = dict(zip(names, sigmas.tolist()))
  print(f"{args.env}: episodes from rest, until they end or {args.steps} steps")
  print("| actions | episodes | mean length | median | std | still up | Brax v1 (v0.0.6; "
        "rotation fixed) |\n| --- | ---: | ---: | ---: | ---: | ---: | --- |")
  for i, (arm, (actions_for, episodes)) in enumerate(arms.items()):
    row = summary(episode_lengths(env, actions_for, jax.random.fold_in(key, i), episodes,
                                  args.steps), args.steps)
    result["arms"][arm] = row
    brax = BRAX.get(args.env, {}).get(arm)
    ref = f"{brax['v0.0.6']:g}; {brax['rotation fixed']:g}" if brax else ""
    print(f"| {arm} | {row['episodes']} | {row['mean']:.1f} | {row['median']:.1f} | "
          f"{row['std']:.1f} | {row['still_up']:.2f} | {ref} |")
  if args.out:
    common.write_json(args.out, result)
    print(f"wrote {args.out}")
  return 0


if __name__ == "__main__":
  raise SystemExit(main())
