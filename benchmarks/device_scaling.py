"""One run's training throughput on 1 and on more devices of this machine, measured in one call.

    python benchmarks/device_scaling.py [--env pro_ant_run] [--env-param num_legs=4 ...]
                                        [--seeds 10] [--devices 1,2] [--chunks 2]
                                        [--iterations 20] [--num-envs N]
                                        [--piece-iterations 5] [--repeats 1]

``training.train`` shards the env axis of every seed over all local devices (seeds stay vmapped
on each). For each device count k this trains the same run (``--env``'s PPO row, the task
objective, ``--seeds`` seeds) for ``--chunks`` chunks of ``--iterations`` PPO iterations, each
followed by PPO's evaluation, in a process of its own that sees the first k devices
(``CUDA_VISIBLE_DEVICES``; on a machine without ``nvidia-smi``, k CPU devices through
``--xla_force_host_platform_device_count``). It prints a Markdown table: compile seconds, env steps
per second per seed over the chunks (the loop's own figure: compilation left out, evaluations
in), and the speed-up over the first device count. The default is ``legs_original``'s four-legged
arm on the ant's row, at the original's physics step.

Where the speed-up goes: after training, the same process times the two programs a chunk of
``train`` runs, each alone on the trained state laid out as ``train`` keeps it
(``training.place_state``), compiled, then called ``--repeats`` times with ``block_until_ready``
(the median): a chunk of ``--piece-iterations`` PPO iterations (given per iteration) and PPO's
evaluation after a chunk (``Trainer.evaluate``: its episodes step one after another). The rest of
``train``'s chunk (its wall time per chunk less ``--iterations`` kernel iterations and one
evaluation) is the host's work that the loop does not hide behind the device (with
``--repeats`` 1, also the calls' noise). A part whose time does not fall with more devices holds
the whole run's speed-up under the device count.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

CHILD = "--child-devices"


def env_params(pairs: list[str]) -> dict:
  """``common.env_params``, a bad pair ending the process with its message."""
  try:
    return common.env_params(pairs)
  except ValueError as err:
    raise SystemExit(f"device_scaling: {err}") from None


def device_counts(text: str) -> list[int]:
  try:
    counts = [int(x) for x in text.split(",")]
  except ValueError:
    counts = []
  if not counts or min(counts) < 1 or len(set(counts)) != len(counts):
    raise SystemExit(f"device_scaling: --devices takes distinct counts of at least 1, e.g. 1,2; "
                     f"got {text!r}")
  return counts


def measure(args, devices: int) -> dict:
  """Trains the run on the ``devices`` local devices this process sees; one row of the table."""
  import jax

  from blx import envs, training
  from blx.objectives import task

  found = len(jax.local_devices())
  if found != devices:
    raise SystemExit(f"device_scaling: asked for {devices} devices, this process sees {found}")
  env = envs.create(args.env, **env_params(args.env_param))
  config = training.ppo_defaults(args.env)
  if args.num_envs:
    config = config.replace(num_envs=args.num_envs)
  steps = config.env_steps_per_iteration * getattr(env, "action_repeat", 1)
  config = config.replace(num_timesteps=args.chunks * args.iterations * steps,
                          num_evals=args.chunks)
  objective = task()
  result = training.train(env, objective, config, seeds=tuple(range(args.seeds)), progress=False)
  last = result.metrics[-1]
  row = dict(devices=devices, device=jax.local_devices()[0].device_kind,
             env_steps=last["env_steps"], compile_s=last["compile_seconds"],
             steps_per_s=last["steps_per_second"])
  trainer = training.make_trainer(env, objective, config)
  pieces = time_pieces(trainer, training.place_state(result.state, config.num_envs),
                       args.piece_iterations, args.repeats)
  chunk_s = last["env_steps"] / last["steps_per_second"] / args.chunks  # train's, per chunk
  rest_s = chunk_s - args.iterations * pieces["iteration_s"] - pieces["evaluation_s"]
  return {**row, **pieces, "chunk_s": chunk_s, "rest_s": rest_s}


def time_pieces(trainer, state, iterations: int, repeats: int) -> dict:
  """Seconds per PPO iteration (a chunk of ``iterations``, alone) and per PPO evaluation (alone)
  on ``state`` (``[seeds, ...]``, laid out as ``train`` keeps it), each the median of ``repeats``
  calls after a first that compiles."""
  import jax
  import numpy as np

  from blx import training

  chunk = jax.jit(jax.vmap(lambda s: trainer.chunk(s, iterations)))  # state and metrics, as train
  evaluate = jax.jit(jax.vmap(lambda s, k: trainer.evaluate(training.policy_params(s), k)))
  keys = lambda i: jax.random.split(jax.random.PRNGKey(i), len(state.env_steps))  # noqa: E731
  _, chunk_times = common.time_calls(chunk, lambda i: (state,), repeats)
  _, eval_times = common.time_calls(evaluate, lambda i: (state, keys(i)), repeats)
  return dict(iteration_s=float(np.median(chunk_times)) / iterations,
              evaluation_s=float(np.median(eval_times)))


def speedups(row: dict, first: dict) -> dict:
  """``row`` with its speed-ups over ``first`` (the first device count's row): the run's (its env
  steps per second) and each piece's (its seconds)."""
  return {**row, "speedup": row["steps_per_s"] / first["steps_per_s"],
          "iteration_speedup": first["iteration_s"] / row["iteration_s"],
          "evaluation_speedup": first["evaluation_s"] / row["evaluation_s"]}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="pro_ant_run")
  parser.add_argument("--env-param", action="append", default=None, metavar="KEY=VALUE",
                      help="an env parameter (repeat for more); default num_legs=4 on pro_ant_run")
  parser.add_argument("--seeds", type=int, default=10)
  parser.add_argument("--devices", default="1,2", help="device counts, e.g. 1,2")
  parser.add_argument("--chunks", type=int, default=2)
  parser.add_argument("--iterations", type=int, default=20, help="PPO iterations per chunk")
  parser.add_argument("--num-envs", type=int, default=None, help="envs per seed (the row's)")
  parser.add_argument("--piece-iterations", type=int, default=5,
                      help="PPO iterations in the chunk timed alone")
  parser.add_argument("--repeats", type=int, default=1,
                      help="timed calls of each piece (their median)")
  parser.add_argument(CHILD, type=int, default=None, help=argparse.SUPPRESS)
  args = parser.parse_args()
  if args.env_param is None:
    args.env_param = ["num_legs=4"] if args.env == "pro_ant_run" else []
  env_params(args.env_param)  # bad pairs fail here, before any process starts
  for name in ("seeds", "chunks", "iterations", "piece_iterations", "repeats"):
    if getattr(args, name) < 1:
      parser.error(f"--{name.replace('_', '-')} must be at least 1, got {getattr(args, name)}")
  if args.child_devices is not None:
    print(json.dumps(measure(args, args.child_devices)), flush=True)
    return

  gpu = shutil.which("nvidia-smi") is not None
  rows = []
  for k in device_counts(args.devices):
    env = dict(os.environ)
    if gpu:
      env["CUDA_VISIBLE_DEVICES"] = ",".join(str(i) for i in range(k))
    else:
      env["XLA_FLAGS"] = (f"{env.get('XLA_FLAGS', '')} "
                          f"--xla_force_host_platform_device_count={k}").strip()
    child = subprocess.run([sys.executable, os.path.abspath(__file__), *sys.argv[1:], CHILD,
                            str(k)], env=env, capture_output=True, text=True)
    if child.returncode:
      sys.exit(f"device_scaling: the run on {k} devices failed:\n{child.stderr[-3000:]}")
    row = json.loads(child.stdout.strip().splitlines()[-1])
    row = speedups(row, rows[0] if rows else row)
    rows.append(row)
    print(json.dumps(row), flush=True)
  common.print_table(
      f"; {' '.join([args.env, *args.env_param])}, {args.seeds} seeds vmapped, "
      f"{args.chunks} chunks of {args.iterations} iterations; the pieces alone: median of "
      f"{args.repeats} calls, the kernel over {args.piece_iterations} iterations", rows,
      [("devices", "devices", ""), ("device", "device", ""), ("env steps per seed", "env_steps",
       ",.0f"), ("compile s", "compile_s", ".1f"), ("env steps/s per seed", "steps_per_s", ",.0f"),
       ("speed-up", "speedup", ".2f"), ("train's chunk s", "chunk_s", ".2f"),
       ("iteration s (alone)", "iteration_s", ".3f"), ("its speed-up", "iteration_speedup", ".2f"),
       ("evaluation s (alone)", "evaluation_s", ".2f"),
       ("its speed-up", "evaluation_speedup", ".2f"), ("rest of the chunk s", "rest_s", ".2f")])


if __name__ == "__main__":
  main()
