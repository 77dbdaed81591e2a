"""Where a DIAYN training iteration on Ant spends its time: physics, policy, discriminator, SGD.

    python benchmarks/profile_ppo.py [--num-envs 16384] [--iterations 5] [--trace-dir DIR]

Two views of the same iteration (the config of ``throughput.py``: 8 skills on xy velocity,
spectral norm, 32 minibatches, 16 unrolls per env):

1. Halves timed apart (``Trainer.collect`` and ``Trainer.update`` are the two halves of an
   iteration), beside raw ``mjx.step`` at the same batch and the same halves for task PPO, so the
   differences give the discriminator's share in the rollout (its reward) and in SGD (its loss).
2. A device trace (``jax.profiler``) of a few whole iterations, with every GPU kernel's time
   assigned by the JAX name scope of the op it runs (``collect/physics``, ``collect/policy``,
   ``collect/objective``, ``update/value``, ``update/policy``, ``update/objective``, the rest of
   ``update`` (Adam, shuffling, normaliser), the rest of ``collect``). Scopes come from the
   compiled HLO's op metadata of the kernel's ``hlo_op``, or else from its ``tf_op`` stat.

Prints Markdown tables; with ``$OUT`` set, writes ``profile.json`` there.
"""

from __future__ import annotations

import argparse
import collections
import glob
import json
import os
import re
import sys
import tempfile
import time

import jax

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
import throughput  # noqa: E402
import train_throughput  # noqa: E402

from blx import envs, training  # noqa: E402
from blx.objectives import task  # noqa: E402

# First match wins: the order puts the specific scopes before their parents.
CATEGORIES = (
    ("rollout: physics", ("collect", "physics")),
    ("rollout: policy", ("collect", "policy")),
    ("rollout: objective reward", ("collect", "objective")),
    ("rollout: other", ("collect",)),
    ("SGD: value net", ("update", "value")),
    ("SGD: policy net", ("update", "policy")),
    ("SGD: objective loss", ("update", "objective")),
    ("SGD: other (Adam, shuffle, normaliser, GAE)", ("update",)),
)


def _config(env_name: str, num_envs: int) -> training.PPOConfig:
  config = training.ppo_defaults(env_name, num_envs=num_envs, batch_size=num_envs // 2,
                                 num_minibatches=32)
  return common.one_iteration_per_chunk(config)


def _time(fn, *args, repeats: int) -> float:
  out = fn(*args)
  jax.block_until_ready(out)
  t = time.perf_counter()
  for _ in range(repeats):
    out = fn(*args)
  jax.block_until_ready(out)
  return (time.perf_counter() - t) / repeats


def halves(env, objective, config, repeats: int) -> dict:
  """Seconds per iteration of collect, update and the whole iteration (jitted separately)."""
  trainer = training.make_trainer(env, objective, config)
  state = jax.jit(trainer.init)(jax.random.PRNGKey(0))
  collect, update = jax.jit(trainer.collect), jax.jit(trainer.update)
  after, data = collect(state)
  return {"collect_s": _time(collect, state, repeats=repeats),
          "update_s": _time(update, after, data, repeats=repeats),
          "iteration_s": _time(jax.jit(trainer.chunk), state, repeats=repeats),
          "steps_per_iteration": config.env_steps_per_iteration}


def _scope_of_hlo_ops(hlo_text: str) -> dict[str, str]:
  """HLO instruction name -> op_name metadata, from a compiled module's text. GPU kernels are
  named after their instruction with "." turned into "_" (``loop_gather_fusion.2`` runs as
  ``loop_gather_fusion_2``), so both spellings are keys."""
  out = {}
  for m in re.finditer(r"%?([\w.\-]+) = [^\n]*?metadata=\{[^}]*op_name=\"([^\"]+)\"", hlo_text):
    out[m.group(1)] = out[m.group(1).replace(".", "_")] = m.group(2)
  return out


def _category(scope: str) -> str:
  for name, parts in CATEGORIES:
    if all(p in scope for p in parts):
      return name
  return "unscoped"


def _kernel_events(profile):
  """The executed ops: GPU kernels on the device planes' stream lines (the "XLA Ops" and
  "XLA Modules" lines repeat the same time and are skipped); on a CPU-only run, host events
  carrying an ``hlo_op`` stat."""
  planes = list(profile.planes)
  device = [p for p in planes if p.name.startswith("/device:")]
  if device:
    for plane in device:
      for line in plane.lines:
        if line.name.lower().startswith("stream"):
          yield from line.events
    return
  for plane in planes:
    for line in plane.lines:
      for event in line.events:
        if "hlo_op" in dict(event.stats):
          yield event


def trace(env, objective, config, iterations: int, trace_dir: str | None) -> dict:
  """GPU kernel time per category over ``iterations`` whole iterations."""
  trainer = training.make_trainer(env, objective, config)
  state = jax.jit(trainer.init)(jax.random.PRNGKey(0))
  chunk = jax.jit(trainer.chunk)
  compiled = chunk.lower(state).compile()
  hlo_scopes = _scope_of_hlo_ops(compiled.as_text())
  state, _ = chunk(state)
  jax.block_until_ready(state)
  directory = trace_dir or tempfile.mkdtemp(prefix="blx_trace_")
  t = time.perf_counter()
  with jax.profiler.trace(directory):
    for _ in range(iterations):
      state, _ = chunk(state)
    jax.block_until_ready(state)
  wall = time.perf_counter() - t
  path = sorted(glob.glob(os.path.join(directory, "**", "*.xplane.pb"), recursive=True))[-1]
  profile = jax.profiler.ProfileData.from_file(path)
  totals, kernels = collections.Counter(), collections.Counter()
  how, samples = collections.Counter(), []
  for event in _kernel_events(profile):
    stats = dict(event.stats)
    scope = hlo_scopes.get(str(stats.get("hlo_op", event.name)), "")
    if scope:
      how["hlo metadata"] += 1
    else:
      scope = str(stats.get("tf_op", "") or "")
      how["tf_op" if scope else "none"] += 1
      if len(samples) < 8 and scope not in samples:
        samples.append(scope)
    category = _category(scope)
    totals[category] += event.duration_ns
    if category == "unscoped":
      kernels[event.name] += event.duration_ns
  busy = sum(totals.values())
  return {"wall_s": wall, "iterations": iterations, "gpu_busy_s": busy * 1e-9,
          "by_category_s": {k: v * 1e-9 for k, v in totals.most_common()},
          "top_unscoped_kernels_s": {k: v * 1e-9 for k, v in kernels.most_common(10)},
          "scope_source_counts": dict(how), "tf_op_samples": samples, "trace": path}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--num-envs", type=int, default=16384)
  parser.add_argument("--iterations", type=int, default=5)
  parser.add_argument("--trace-dir", default=None)
  parser.add_argument("--env", default="ant", help="ant, or point for a quick check on a CPU")
  args = parser.parse_args()
  env = envs.create(args.env)
  config = _config(args.env, args.num_envs)
  diayn = throughput.diayn(env)
  result = {"device": jax.devices()[0].device_kind, "jax": jax.__version__,
            "num_envs": args.num_envs, "steps_per_iteration": config.env_steps_per_iteration}
  result["raw_physics_steps_per_s"] = train_throughput.raw_physics(env, args.num_envs)
  result["diayn"] = halves(env, diayn, config, args.iterations)
  result["task"] = halves(env, task(), config, args.iterations)
  print(json.dumps(result), flush=True)
  result["trace"] = trace(env, diayn, config, args.iterations, args.trace_dir)
  print(json.dumps(result["trace"]), flush=True)

  steps = config.env_steps_per_iteration
  raw_s = steps / result["raw_physics_steps_per_s"]
  d, t = result["diayn"], result["task"]
  print(f"\ndevice: {result['device']}; jax {result['jax']}; num_envs {args.num_envs}; "
        f"{steps:,} env steps per iteration")
  print("| part (seconds per iteration) | DIAYN | task PPO | share of DIAYN iteration |")
  print("| --- | ---: | ---: | ---: |")
  print(f"| raw mjx.step, same steps | {raw_s:.3f} | {raw_s:.3f} | {raw_s / d['iteration_s']:.0%} |")
  for key, label in (("collect_s", "collect (policy + physics + reward)"),
                     ("update_s", "update (normaliser + SGD)"), ("iteration_s", "iteration")):
    print(f"| {label} | {d[key]:.3f} | {t[key]:.3f} | {d[key] / d['iteration_s']:.0%} |")
  tr = result["trace"]
  print(f"\ntrace: {tr['iterations']} iterations, {tr['wall_s']:.3f} s wall, GPU kernels busy "
        f"{tr['gpu_busy_s']:.3f} s (scopes from {tr['scope_source_counts']})")
  print("| category | GPU seconds per iteration | share of kernel time |")
  print("| --- | ---: | ---: |")
  for k, v in tr["by_category_s"].items():
    print(f"| {k} | {v / tr['iterations']:.4f} | {v / max(tr['gpu_busy_s'], 1e-12):.0%} |")
  out = os.environ.get("OUT")
  if out:
    with open(os.path.join(out, "profile.json"), "w") as f:
      json.dump(result, f, indent=1)


if __name__ == "__main__":
  main()
