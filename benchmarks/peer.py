"""Brax's PPO and blx's PPO side by side, on the same settings, in one process.

    python benchmarks/peer.py [--num-envs 16384] [--batch-size 8192] [--steps 105000000]
        [--num-evals 10] [--order brax,blx] [--out DIR]

The task is the MuJoCo ant on MJX with the same physics on both sides: Brax's
``envs.get_environment("ant", backend="mjx")`` (its ant.xml: 10 ms steps, 5 per control step,
Newton with 1 iteration and 4 line searches, Euler damping off) and blx's ``gym_ant`` (the same
MuJoCo ant, the same solver settings). Both train task PPO with the Braxlines ant row (unroll 5,
32 minibatches, 4 epochs, lr 3e-4, entropy 1e-2, discount 0.97, reward scaling 10, normalised
observations, 1000-step episodes) and the ``--num-envs`` / ``--batch-size`` / ``--steps`` /
``--num-evals`` given.

Printed per side: the wall time from the call (env build and compilation included) to the end, the
time to the first evaluation, and the steady rate: the median over the intervals between two
evaluations of env steps per second (evaluations included; ``steady_rate``). The rewards are
printed too, but the two ants' rewards are not the same function (Brax's has a contact cost and
its own healthy rule), so only the timings compare. Skips, saying so, where brax is not installed
(carry its wheel to the GPU machine: ``../shared/gpu/fetch-wheels.sh`` includes brax 0.14.2).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

ROW = dict(unroll_length=5, num_minibatches=32, num_updates_per_batch=4, learning_rate=3e-4,
           entropy_cost=1e-2, discounting=0.97, reward_scaling=10.0)


def replicated(x, devices):
  """What ``jax.device_put_replicated(x, devices)`` returned: every leaf stacked once per device on
  a new leading axis, one slice on each device (the layout ``jax.pmap`` takes). It is made by a
  ``jax.pmap`` that broadcasts ``x`` over brax's axis name ``"i"``, so it carries the sharding of
  the outputs of brax's own pmapped training step: an array placed with ``jax.device_put`` and a
  NamedSharding made that step trace and compile a second time on its second call (session 13),
  and a pmap of another axis name made brax's jitted evaluator compile once more when it first met
  the trained state (session 15, 36 s on an H200)."""
  import jax
  import jax.numpy as jnp
  devices = list(devices)
  return jax.pmap(lambda _, t: t, in_axes=(0, None), axis_name="i", devices=devices)(
      jnp.arange(len(devices)), jax.tree.map(jnp.asarray, x))


def patch_jax_for_brax() -> bool:
  """brax 0.14.2's PPO calls ``jax.device_put_replicated``, which jax 0.10+ no longer provides (its
  pmap migration guide names ``jax.device_put`` instead). Puts :func:`replicated` in its place for
  brax's sake when it is missing; True if it did. blx itself never calls it."""
  import jax
  try:
    jax.device_put_replicated  # noqa: B018
    return False
  except AttributeError:
    jax.device_put_replicated = replicated
    return True


def run_brax(args) -> dict:
  from brax import envs as brax_envs
  from brax.training.agents.ppo import train as brax_ppo
  rows = []
  start = time.time()

  def progress(steps, metrics):
    rows.append({"wall_s": time.time() - start, "env_steps": int(steps),
                 "reward": float(metrics.get("eval/episode_reward", float("nan")))})
    print(json.dumps({"side": "brax", **rows[-1]}), flush=True)

  env = brax_envs.get_environment("ant", backend="mjx")
  brax_ppo.train(environment=env, num_timesteps=args.steps, num_envs=args.num_envs,
                 batch_size=args.batch_size, episode_length=1000, normalize_observations=True,
                 num_evals=args.num_evals, seed=0, progress_fn=progress, **ROW)
  return {"side": "brax", "wall_s": time.time() - start, "rows": rows}


def run_blx(args) -> dict:
  sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
  from blx import envs, training
  from blx.objectives import task
  rows = []
  start = time.time()

  def progress(row):
    rows.append({"wall_s": time.time() - start, "env_steps": int(row["env_steps"]),
                 "reward": float(row["eval/episode_reward"][0])})
    print(json.dumps({"side": "blx", **rows[-1]}), flush=True)

  env = envs.create("gym_ant")
  config = training.ppo_defaults("ant", num_envs=args.num_envs, batch_size=args.batch_size,
                                 num_timesteps=args.steps, num_evals=args.num_evals, **ROW)
  training.train(env, task(), config, seeds=(0,), progress=progress)
  return {"side": "blx", "wall_s": time.time() - start, "rows": rows}


def steady_rate(rows: list[dict]) -> float | None:
  """The median of the env steps per second between consecutive evaluations: robust to a chunk
  that compiled (brax compiles its training step after its evaluation at step 0) and to two
  reports that come together (blx's last two, before session 13's loop), which a rate between the
  first and the last evaluation is not."""
  rates = [(b["env_steps"] - a["env_steps"]) / (b["wall_s"] - a["wall_s"])
           for a, b in zip(rows, rows[1:])
           if b["env_steps"] > a["env_steps"] and b["wall_s"] - a["wall_s"] > 0.05]
  return float(np.median(rates)) if rates else None


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--num-envs", type=int, default=16384)
  parser.add_argument("--batch-size", type=int, default=8192)
  parser.add_argument("--steps", type=int, default=105_000_000)
  parser.add_argument("--num-evals", type=int, default=10)
  parser.add_argument("--order", default="brax,blx", help="which side runs first")
  parser.add_argument("--out", default=None, help="writes peer.json there")
  args = parser.parse_args()
  order = args.order.split(",")
  if sorted(order) != ["blx", "brax"]:
    parser.error(f"--order {args.order!r}: expected 'brax,blx' or 'blx,brax'")
  try:
    import brax  # noqa: F401
    from brax.training.agents.ppo import train  # noqa: F401
  except Exception as e:  # not installed, or an import that fails on this jax
    print(f"peer: skipped, brax's PPO cannot be imported here ({type(e).__name__}: {e}); carry "
          "the brax wheel (../shared/gpu/fetch-wheels.sh)")
    return
  import jax
  if patch_jax_for_brax():
    print(f"peer: jax {jax.__version__} has no device_put_replicated; brax gets an equivalent "
          "built on jax.device_put (peer.replicated)", flush=True)
  results = []
  for side in order:
    try:
      results.append(run_brax(args) if side == "brax" else run_blx(args))
    except Exception as e:  # e.g. a Brax release that calls an API this jax removed
      if side == "blx":
        raise
      print(f"peer: brax's run failed: {type(e).__name__}: {str(e)[:300]}", flush=True)
      results.append({"side": "brax", "wall_s": float("nan"), "rows": [],
                      "error": f"{type(e).__name__}: {e}"})
  print(f"\nant (MuJoCo ant on MJX, both sides), {args.num_envs:,} envs, batch "
        f"{args.batch_size:,}, {args.steps:,} steps, {args.num_evals} evaluations; jax "
        f"{jax.__version__} on {jax.devices()[0].device_kind}; order {args.order}")
  print("| side | wall s (from the call) | first evaluation at (s) | steady env steps/s | "
        "final reward (not comparable) |")
  print("| --- | ---: | ---: | ---: | ---: |")
  for r in results:
    if "error" in r:
      print(f"| {r['side']} | failed: {r['error'][:80]} | | | |")
      continue
    rate = steady_rate(r["rows"])
    first = r["rows"][0]["wall_s"] if r["rows"] else float("nan")
    final = r["rows"][-1]["reward"] if r["rows"] else float("nan")
    print(f"| {r['side']} | {r['wall_s']:.1f} | {first:.1f} | "
          f"{'-' if rate is None else f'{rate:,.0f}'} | {final:.1f} |")
  if args.out:
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "peer.json"), "w") as f:
      json.dump({"args": vars(args), "results": results}, f, indent=1)


if __name__ == "__main__":
  main()
