"""Env steps/s of every registered env beside raw ``mjx.step`` throughput of the same model.

    python benchmarks/env_throughput.py [--num-envs 4096] [--steps 100] [--envs ant,humanoid]
        [--edits JSON [--edits JSON ...]]

For each env: the jitted, vmapped ``env.step`` (physics substeps + observations + rewards +
termination) scanned for ``--steps`` steps, and the bare ``mjx.step`` on the same compiled model run
``substeps`` times per env step. The ratio env/raw is the env's overhead. Prints a Markdown table
(and with --json, one JSON line per env).

Each ``--edits`` (a JSON object of ``{"dotted.path": value}``, as ``blx.envs.create`` takes)
measures every env once more with those edits, e.g. the humanoid's observation with and without the
observer ``"com"``, in one call: ``--envs humanoid --edits '{}' --edits
'{"components.agent1.observers": ["root_z_joints", "cfrc", "actuator", "com"]}'``. Without it each
env is measured as registered.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import jax

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
import paper_tables  # noqa: E402

from blx import envs  # noqa: E402


def parse_edits(text: str) -> dict:
  """``--edits``' JSON object, parsed as paper_tables.py's ``--env-edits``."""
  try:
    return paper_tables.json_object(text, 'env edits (e.g. {"global_options.substeps": 8})')
  except ValueError as e:
    raise argparse.ArgumentTypeError(str(e)) from None


def _time(fn, *args, repeats=3):
  out = fn(*args)
  jax.block_until_ready(out)
  best = float("inf")
  for _ in range(repeats):
    t = time.perf_counter()
    jax.block_until_ready(fn(*args))
    best = min(best, time.perf_counter() - t)
  return best


def measure(name: str, num_envs: int, steps: int, edits: dict | None = None) -> dict:
  env = envs.unwrap(envs.create(name, edits=edits))
  t0 = time.perf_counter()
  run_env, (state, actions) = common.env_step_runner(env, num_envs, steps)
  run_raw = common.raw_physics_runner(env)

  jax.block_until_ready(run_env(state, actions))
  compile_s = time.perf_counter() - t0
  env_s = _time(run_env, state, actions)
  raw_s = _time(run_raw, state.data, actions)
  env_sps, raw_sps = num_envs * steps / env_s, num_envs * steps / raw_s
  return dict(env=name, edits=edits or {}, obs_size=env.observation_size, num_envs=num_envs,
              substeps=env.substeps, env_steps_per_s=env_sps,
              raw_env_steps_per_s=raw_sps, raw_physics_steps_per_s=raw_sps * env.substeps,
              ratio=env_sps / raw_sps, compile_s=compile_s)


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--num-envs", type=int, default=4096)
  parser.add_argument("--steps", type=int, default=100)
  parser.add_argument("--envs", default=",".join(envs.list_envs()))
  parser.add_argument("--edits", action="append", type=parse_edits, metavar="JSON",
                      help="env edits, a JSON object of {dotted.path: value}; each measures every "
                           "env once more (default: the envs as registered)")
  parser.add_argument("--json", action="store_true")
  args = parser.parse_args()
  rows = []
  for name in args.envs.split(","):
    for edits in args.edits or [{}]:
      row = measure(name, args.num_envs, args.steps, edits)
      rows.append(dict(row, edits_text=json.dumps(row["edits"])))
      if args.json:
        print(json.dumps(row), flush=True)
  common.print_table(f"; num_envs {args.num_envs}", rows, [
      ("env", "env", ""), ("edits", "edits_text", ""), ("obs", "obs_size", "d"),
      ("env steps/s", "env_steps_per_s", ",.0f"),
      ("raw mjx.step (env-step equiv.)/s", "raw_env_steps_per_s", ",.0f"),
      ("raw physics steps/s", "raw_physics_steps_per_s", ",.0f"), ("env/raw", "ratio", ".2f"),
      ("compile s", "compile_s", ".1f")])

if __name__ == "__main__":
  main()
