"""Where one chunk of a time-to-quality run goes: the training kernel, PPO's own evaluation
episodes and the paper's evaluator, each timed alone on the device, and the two evaluations
together as ``training.train`` runs them.

    python benchmarks/chunk_costs.py [--objective diayn] [--num-envs 16384] [--repeats 3]
        [--num-evals 20] [--steps 100000000] [--config JSON] [--env ant] [--quick-eval]

The run is the one ``time_to_quality.py`` builds (the paper's objective settings and the env's PPO
row with ``num_envs`` set, ``--config`` over it). Per chunk ``training.train`` runs the chunk of
PPO iterations, then ``Trainer.evaluate`` (the trainer's evaluation episodes behind
``eval/episode_reward``) and, with an evaluator, the paper's metric (``blx.metrics.evaluator_for``),
their episodes stepped in one rollout (``training.evaluate_together``; before session 14 one after
the other). Each part is compiled, then called ``--repeats`` times with ``block_until_ready`` after
each call; the table gives the median seconds per call, and the share of a chunk as ``train`` runs
it (the kernel and the evaluations together) for the parts it runs. Prints one JSON line last.

The paper's evaluator is timed in both of its protocols (``runs.EVAL_PROTOCOLS``): the final
evaluation's (10 episodes; what ``time_to_quality.py`` logs by default) and the quick one (4; what
``blx train --eval-metrics`` logs by default, and ``time_to_quality.py --quick-eval``). The share
counts the one ``--quick-eval`` names (the final one without it), as ``time_to_quality.py``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import jax
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
import time_to_quality  # noqa: E402

from blx import training  # noqa: E402
from blx.experiments import runs  # noqa: E402


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="ant")
  parser.add_argument("--objective", default="diayn", choices=sorted(time_to_quality.QUALITY))
  parser.add_argument("--num-envs", type=int, default=16384)
  parser.add_argument("--steps", type=int, default=100_000_000)
  parser.add_argument("--num-evals", type=int, default=20)
  parser.add_argument("--repeats", type=int, default=3)
  parser.add_argument("--config", default=None, metavar="JSON",
                      help="PPO settings over the row, e.g. '{\"batch_size\": 4096}'")
  parser.add_argument("--quick-eval", action="store_true",
                      help="count the quick protocol's evaluation in the chunk's share (4 "
                           "episodes), not the final one's (10); both are timed")
  args = parser.parse_args()
  if args.repeats < 1:
    parser.error(f"--repeats must be at least 1, got {args.repeats}")
  try:
    settings = json.loads(args.config) if args.config else {}
  except json.JSONDecodeError:
    settings = None
  if not isinstance(settings, dict):
    parser.error(f"--config {args.config!r}: give a JSON object, e.g. '{{\"batch_size\": 4096}}'")
  spec = time_to_quality.arm_spec(args.env, args.objective, args.num_envs, 1, args.steps,
                                  args.num_evals, settings)
  env, objective, config = runs.build(spec)
  trainer = training.make_trainer(env, objective, config)
  evaluators = {protocol: runs.evaluator_for(env, objective, quick=protocol == "quick")
                for protocol in runs.EVAL_PROTOCOLS}
  evaluator = evaluators["final"]
  counted = "quick" if args.quick_eval else "final"
  params = training.policy_params
  state = jax.jit(jax.vmap(trainer.init))(jax.random.PRNGKey(0)[None])
  keys = lambda i: jax.random.PRNGKey(i)[None]  # noqa: E731

  chunk = jax.jit(jax.vmap(trainer.chunk))
  ppo_eval = jax.jit(jax.vmap(lambda s, k: trainer.evaluate(params(s), k)))
  # (name, function, its arguments for call i, whether train runs it per chunk)
  parts = [("training chunk", lambda s: chunk(s)[0], lambda i: (state,), True)]
  parts.append(("PPO's evaluation episodes" + (", alone" if evaluator else ""), ppo_eval,
                lambda i: (state, keys(i)), evaluator is None))
  for protocol, one in evaluators.items() if evaluator is not None else ():
    paper_eval = jax.jit(jax.vmap(lambda s, k, one=one: one(trainer.policy, params(s), k)))
    both = training.evaluate_together(trainer, one)
    together = jax.jit(jax.vmap(lambda s, k, j, both=both: both(params(s), k, j)))
    parts.append((f"the paper's evaluator ({protocol} protocol), alone", paper_eval,
                  lambda i: (state, keys(i)), False))
    parts.append((f"both evaluations in one rollout ({protocol} protocol)", together,
                  lambda i: (state, keys(i), keys(1000 + i)), protocol == counted))
  rows = []
  for name, fn, args_for, in_train in parts:
    compile_s, times = common.time_calls(fn, args_for, args.repeats)
    rows.append({"part": name, "first_call_s": compile_s, "seconds": float(np.median(times)),
                 "all_s": times, "in_train": in_train})
  total = sum(r["seconds"] for r in rows if r["in_train"])
  for r in rows:
    r["share"] = f"{r['seconds'] / total:.0%}" if r["in_train"] else "-"
  steps = trainer.iterations_per_chunk * trainer.env_steps_per_iteration
  common.print_table(
      f"; {args.env}, {args.objective}, {args.num_envs:,} envs, batch {config.batch_size:,} x "
      f"{config.num_minibatches}, {trainer.iterations_per_chunk} iterations = {steps:,} env steps "
      f"per chunk; median of {args.repeats} calls; the share counts the {counted} protocol", rows,
      [("part", "part", "s"), ("first call (compile) s", "first_call_s", ".1f"),
       ("seconds per chunk", "seconds", ".3f"), ("share of train's chunk", "share", "s")])
  print(json.dumps({"env": args.env, "objective": args.objective, "num_envs": args.num_envs,
                    "counted_protocol": counted,
                    "batch_size": config.batch_size, "num_minibatches": config.num_minibatches,
                    "env_steps_per_chunk": steps,
                    "kernel_env_steps_per_s": steps / rows[0]["seconds"], "train_chunk_s": total,
                    "parts": rows,
                    "device": jax.devices()[0].device_kind, "jax": jax.__version__}))


if __name__ == "__main__":
  main()
