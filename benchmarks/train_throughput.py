"""PPO training throughput on Ant beside raw ``mjx.step`` throughput, measured in one run.

    python benchmarks/train_throughput.py [--num-envs 2048,4096,8192,16384] [--iterations 20]
        [--env ant] [--edits JSON [--edits JSON ...]]

For each num_envs: the ant row of ``ppo_defaults`` (num_envs changed; batch_size * num_minibatches
= num_envs / 2, 32 minibatches: 16 unrolls per env per iteration as the original), time from start to the first finished training chunk (compile
included), then env steps/s of the jitted chunk; raw physics is ``mjx.step`` on the same model at the
same batch, expressed per env step (``substeps`` physics steps). Prints a Markdown table.

Each ``--edits`` (a JSON object of ``{"dotted.path": value}``, as ``blx.envs.create`` takes) times
every num_envs once more on the env with those edits, in the same process, e.g. the ant's contact
solve with one Newton iteration (its registered setting) and with four: ``--edits '{}' --edits
'{"global_options.iterations": 4}'``. Without it the env is timed as registered.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import jax
import jax.numpy as jnp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
import env_throughput  # noqa: E402

from blx import envs, training  # noqa: E402
from blx.objectives import task  # noqa: E402


def raw_physics(env, num_envs: int, steps: int = 50) -> float:
  base = envs.unwrap(env)
  data = jax.jit(jax.vmap(base.reset))(jax.random.split(jax.random.PRNGKey(0), num_envs)).data
  actions = jnp.zeros((steps, num_envs, base.action_size))  # ctrl stays 0, as at reset
  run = common.raw_physics_runner(env)
  jax.block_until_ready(run(data, actions))
  t = time.perf_counter()
  jax.block_until_ready(run(data, actions))
  return num_envs * steps / (time.perf_counter() - t)


def measure(env_name: str, num_envs: int, iterations: int, objective=None,
            raw_sps: float | None = None, edits: dict | None = None) -> dict:
  """One row; ``objective(env) -> Objective`` (default task); ``raw_sps`` reuses a raw-physics
  figure measured at the same num_envs instead of measuring it again; ``edits`` are env edits
  (``blx.envs.create``'s)."""
  env = envs.create(env_name, edits=edits)
  # Keep the ant row's 16 unrolls per env per iteration (2048 envs, batch 1024, 32 minibatches).
  config = training.ppo_defaults(env_name, num_envs=num_envs, batch_size=num_envs // 2,
                                 num_minibatches=32)
  config = common.one_iteration_per_chunk(config)
  objective = objective(env) if callable(objective) else task()
  trainer = training.make_trainer(env, objective, config)
  assert trainer.iterations_per_chunk == 1
  t0 = time.perf_counter()
  state = jax.jit(trainer.init)(jax.random.PRNGKey(0))
  chunk = jax.jit(trainer.chunk)
  state, _ = chunk(state)
  jax.block_until_ready(state.params)
  first_step_s = time.perf_counter() - t0
  t = time.perf_counter()
  for _ in range(iterations):
    state, metrics = chunk(state)
  jax.block_until_ready(state.params)
  train_sps = config.env_steps_per_iteration * iterations / (time.perf_counter() - t)
  raw_sps = raw_sps or raw_physics(env, num_envs)
  return dict(env=env_name, edits=edits or {}, substeps=envs.unwrap(env).substeps,
              objective=objective.name, num_envs=num_envs, batch_size=config.batch_size,
              num_minibatches=config.num_minibatches, train_env_steps_per_s=train_sps,
              raw_env_steps_per_s=raw_sps, ratio=train_sps / raw_sps,
              start_to_first_step_s=first_step_s,
              steps_per_iteration=config.env_steps_per_iteration)


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="ant")
  parser.add_argument("--num-envs", default="2048,4096,8192,16384")
  parser.add_argument("--iterations", type=int, default=10)
  parser.add_argument("--edits", action="append", type=env_throughput.parse_edits, metavar="JSON",
                      help="env edits, a JSON object of {dotted.path: value}; each times every "
                           "num_envs once more with those edits (default: the env as registered)")
  args = parser.parse_args()
  rows = []
  for edits in args.edits or [{}]:
    for n in [int(x) for x in args.num_envs.split(",")]:
      row = measure(args.env, n, args.iterations, edits=edits)
      rows.append(dict(row, edits_text=json.dumps(row["edits"])))
      print(json.dumps(row), flush=True)
  common.print_table("", rows, [
      ("env", "env", ""), ("edits", "edits_text", ""), ("num_envs", "num_envs", ""),
      ("train env steps/s", "train_env_steps_per_s", ",.0f"),
      ("raw physics env steps/s", "raw_env_steps_per_s", ",.0f"), ("train/raw", "ratio", ".2f"),
      ("start to first step s", "start_to_first_step_s", ".1f")])

if __name__ == "__main__":
  main()
