"""What the host loop of ``blx.training.train`` costs: its steady-state rate beside the training
kernel alone, measured in one process with identical settings.

    python benchmarks/host_loop.py [--env ant] [--num-envs 16384] [--batch-size 8192]
                                   [--chunks 10] [--iterations-per-chunk 8] [--checkpoint]

``train`` runs ``--chunks`` chunks of ``--iterations-per-chunk`` PPO iterations, evaluating,
reporting (and with ``--checkpoint`` writing a checkpoint) after each; its steady-state rate is
the env steps between the first and the last report over the wall time between them (compile
excluded). The kernel alone is the same jitted chunk called back to back; PPO's evaluation
(``Trainer.evaluate``) is timed alone too, since ``train`` runs it after every chunk on the same
device. Prints one JSON line, the ratio train / kernel (issue #13 asks for >= 0.9) and the bound
kernel / (kernel + evaluation) that the evaluation leaves.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import jax

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import envs, training  # noqa: E402
from blx.objectives import task  # noqa: E402


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="ant")
  parser.add_argument("--num-envs", type=int, default=16384)
  parser.add_argument("--batch-size", type=int, default=8192)
  parser.add_argument("--num-minibatches", type=int, default=32)
  parser.add_argument("--chunks", type=int, default=10)
  parser.add_argument("--iterations-per-chunk", type=int, default=8)
  parser.add_argument("--checkpoint", action="store_true")
  args = parser.parse_args()

  env = envs.create(args.env)
  config = training.ppo_defaults(args.env, num_envs=args.num_envs, batch_size=args.batch_size,
                                 num_minibatches=args.num_minibatches, num_evals=args.chunks)
  config = config.replace(num_timesteps=config.env_steps_per_iteration
                          * args.iterations_per_chunk * args.chunks)
  objective = task()

  times, steps = [], []

  def report(row):
    times.append(time.perf_counter())
    steps.append(row["env_steps"])

  with tempfile.TemporaryDirectory() as tmp:
    t0 = time.perf_counter()
    training.train(env, objective, config, progress=report,
                   checkpoint_dir=tmp if args.checkpoint else None)
    wall = time.perf_counter() - t0
  if len(times) < 3:
    raise SystemExit(f"only {len(times)} reports; give --chunks >= 3")
  train_sps = (steps[-1] - steps[0]) / (times[-1] - times[0])

  trainer = training.make_trainer(env, objective, config)
  chunk = jax.jit(jax.vmap(trainer.chunk))
  state = jax.jit(jax.vmap(trainer.init))(jax.random.PRNGKey(0)[None])
  state, _ = chunk(state)
  jax.block_until_ready(state)
  t = time.perf_counter()
  for _ in range(args.chunks - 1):
    state, _ = chunk(state)
  jax.block_until_ready(state)
  kernel_sps = (config.env_steps_per_iteration * trainer.iterations_per_chunk
                * (args.chunks - 1) / (time.perf_counter() - t))
  # PPO's evaluation after each chunk runs on the same device stream, so train can at best take
  # kernel + evaluation per chunk.
  evaluate = jax.jit(jax.vmap(lambda s, k: trainer.evaluate(training.policy_params(s), k)))
  _, eval_times = common.time_calls(evaluate, lambda i: (state, jax.random.PRNGKey(1 + i)[None]), 3)
  eval_s = sum(eval_times) / len(eval_times)
  chunk_s = config.env_steps_per_iteration * trainer.iterations_per_chunk / kernel_sps
  row = dict(env=args.env, num_envs=args.num_envs, batch_size=args.batch_size,
             iterations_per_chunk=trainer.iterations_per_chunk, chunks=trainer.num_chunks,
             checkpoint=args.checkpoint, train_wall_s=wall, train_steady_env_steps_per_s=train_sps,
             kernel_env_steps_per_s=kernel_sps, ratio=train_sps / kernel_sps,
             kernel_s_per_chunk=chunk_s, evaluation_s_per_chunk=eval_s,
             ratio_bound_with_evaluation=chunk_s / (chunk_s + eval_s),
             device=str(jax.devices()[0]), jax=jax.__version__)
  print(json.dumps(row))
  print(f"train steady state / kernel alone: {row['ratio']:.3f}; kernel / (kernel + PPO's "
        f"evaluation), the most a loop that evaluates every chunk can reach: "
        f"{row['ratio_bound_with_evaluation']:.3f}")


if __name__ == "__main__":
  main()
