"""Replays one seed of a run from its checkpoint, one training iteration at a time (#15).

    python benchmarks/replay_chunk.py RUN_DIR --seed 4 [--iterations 16] [--out FILE.json]

A run stopped by a non-finite loss keeps its last good checkpoint (``training.NonFiniteError``);
this script takes that checkpoint's state for one seed and runs the iterations that followed it
(``Trainer.collect`` then ``Trainer.update``, as a chunk does) on this machine, printing each
iteration's PPO statistics: the loss's terms, the gradient norm, ``policy/log_ratio_max`` (PPO's
ratio overflows float32 above about 88.7) and the policy's entropy, and at a non-finite iteration
the report ``train`` gives. A checkpoint written without the envs' state starts
every env anew, as a resume does.

The replay is the run's own computation for that seed, but on another device (or another XLA
build) floating point differs, and the rollouts part from the original's within some steps: a
replay that stays finite says the failure depends on the run's exact numbers, not that it cannot
recur; one that fails names where.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import jax
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402,F401  (the repository on the path)

from blx import training  # noqa: E402
from blx.experiments import runs  # noqa: E402
from blx.training import checkpoint, loop  # noqa: E402

SHOWN = ("loss/policy", "loss/value", "loss/entropy", "loss/objective", "grad_norm",
         "grad_clipped", "policy/log_ratio_max", "policy/entropy")


def seed_state(run_dir: str, seed: int):
  """The trainer and seed ``seed``'s ``TrainState`` from ``run_dir``'s checkpoint (its envs new
  where the checkpoint has none), and the checkpoint's metadata."""
  spec = runs.read_spec(run_dir)
  if seed not in spec.seeds:
    raise SystemExit(f"replay_chunk: --seed {seed}: the run's seeds are {list(spec.seeds)}")
  env, objective, config = runs.build(spec)
  trainer = training.make_trainer(env, objective, config)
  init_keys, _ = loop.run_keys(spec.seeds)
  like = jax.eval_shape(jax.vmap(trainer.init), init_keys)
  state, meta = training.restore_state(os.path.join(run_dir, "checkpoint"), like)
  index = list(spec.seeds).index(seed)
  state = jax.tree.map(lambda x: x[index], state)  # (an absent env_state stays None)
  if state.env_state is None:  # as train's resume: the seed's envs anew from its init key
    state = state.replace(env_state=jax.jit(trainer.init)(init_keys[index]).env_state)
  return trainer, state, meta


def replay(run_dir: str, seed: int, iterations: int | None = None, *, show: bool = True):
  """Replays seed ``seed`` of ``run_dir`` from its checkpoint for ``iterations`` iterations
  (default one chunk's), stopping after the first non-finite one: ``(rows, error, state)``, the
  iterations' statistics, ``train``'s report of the non-finite iteration (None if none) and the
  seed's ``TrainState`` after the last iteration run."""
  trainer, state, meta = seed_state(run_dir, seed)
  iterations = trainer.iterations_per_chunk if iterations is None else iterations
  if iterations < 1:
    raise SystemExit(f"replay_chunk: --iterations {iterations}: give at least 1")
  # the state's own count: a checkpoint written within a chunk (train's checkpoint_segments) is
  # past the chunk's start
  first = int(state.iteration)
  if show:
    within = first - int(meta["chunk"]) * trainer.iterations_per_chunk
    print(f"seed {seed} from the checkpoint after chunk {meta['chunk']}"
          f"{f' and {within} iterations of the next' if within else ''} (iteration {first}, "
          f"{float(state.env_steps):,.0f} env steps), {iterations} iterations on "
          f"{jax.devices()[0].platform}", flush=True)
  collect, update = jax.jit(trainer.collect), jax.jit(trainer.update)
  rows, error = [], None
  for i in range(iterations):
    t0 = time.time()
    state, data = collect(state)
    state, metrics = update(state, data)
    metrics = jax.device_get(metrics)
    row = {"iteration": first + i, "seconds": round(time.time() - t0, 2),
           **{k: float(metrics[k]) for k in SHOWN if k in metrics}}
    rows.append(row)
    if show:
      print("  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                      for k, v in row.items()), flush=True)
    try:  # the report train gives, for this one iteration
      loop._check_finite({k: np.asarray(v).reshape(1, 1) for k, v in metrics.items()
                          if k.startswith("nonfinite/")}, first + i, [seed], None)
    except training.NonFiniteError as e:
      error = str(e)
      if show:
        print(error, flush=True)
      break
  return rows, error, state


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
  parser.add_argument("run_dir")
  parser.add_argument("--seed", type=int, required=True, help="the seed to replay (its value)")
  parser.add_argument("--iterations", type=int, default=None,
                      help="iterations to replay (default: one chunk's)")
  parser.add_argument("--out", help="also write the iterations' statistics to this JSON file")
  args = parser.parse_args(argv)
  try:
    rows, error, _ = replay(args.run_dir, args.seed, args.iterations)
  except (runs.RunError, checkpoint.CheckpointError, OSError) as e:  # not a run, no checkpoint
    parser.error(f"{args.run_dir}: {e}")
  if args.out:
    with open(args.out, "w") as f:
      json.dump({"run": args.run_dir, "seed": args.seed, "device": jax.devices()[0].platform,
                 "jax": jax.__version__, "iterations": rows, "non_finite": error}, f, indent=1)
  return 0


if __name__ == "__main__":
  sys.exit(main())
