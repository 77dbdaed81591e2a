"""DIAYN on Ant on one GPU: raw physics, task PPO and DIAYN training throughput, and the wall time
until DIAYN first reaches the paper's MI.

    python benchmarks/throughput.py [--num-envs 4096,8192,16384] [--iterations 10]
                                    [--mi-steps 60000000 --mi-envs 2048]

Part 1, for each num_envs: start to first training step (compile included), env steps/s of plain
PPO (task reward) and of DIAYN (8 skills on xy velocity, spectral norm, the discriminator trained in
the same SGD step), raw ``mjx.step`` at the same batch, and the ratios. The DIAYN/task ratio is the
cost of the discriminator; train/raw is the share of time spent in physics.

Part 2: a DIAYN run with the paper's settings (ant row, obs_scale 5, spectral norm) evaluated with
the paper's MI estimator at every evaluation; prints the wall time (compile included) at which MI
first reaches 1.115 (the paper's Ant DIAYN figure).
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
import train_throughput  # noqa: E402

from blx import envs, metrics, objectives, training  # noqa: E402

PAPER_MI = 1.115


def diayn(env):
  return objectives.diayn(num_skills=8, obs_indices="vel", env=env, spectral_norm=True)


def time_to_mi(steps: int, num_envs: int) -> dict:
  env = envs.create("ant")
  obj = diayn(env)
  config = training.ppo_defaults("ant", num_timesteps=steps, num_envs=num_envs,
                                 batch_size=num_envs // 2, num_evals=20)
  evaluator = metrics.mimax_evaluator(env, obj, num_latents=8, episodes_per_latent=10,
                                      last_steps=500, num_goals=10)
  rows = []
  t0 = time.perf_counter()

  def record(r):
    rows.append({"time": time.perf_counter() - t0, "env_steps": r["env_steps"],
                 "mi": r["eval/mi"][0], "entropy": r["eval/entropy"][0], "lgr": r["eval/lgr"][0],
                 "steps_per_s": r["steps_per_second"]})
    print(json.dumps(rows[-1]), flush=True)

  training.train(env, obj, config, progress=record, evaluate=evaluator)
  reached = next((r for r in rows if r["mi"] >= PAPER_MI), None)
  return {"rows": rows, "time_to_paper_mi_s": reached and reached["time"],
          "steps_to_paper_mi": reached and reached["env_steps"], "num_envs": num_envs,
          "total_time_s": rows[-1]["time"]}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--num-envs", default="4096,8192,16384")
  parser.add_argument("--iterations", type=int, default=10)
  parser.add_argument("--mi-steps", type=int, default=60_000_000)
  parser.add_argument("--mi-envs", type=int, default=2048)
  parser.add_argument("--skip-throughput", action="store_true")
  args = parser.parse_args()
  rows = []
  if not args.skip_throughput:
    for n in [int(x) for x in args.num_envs.split(",")]:
      task_row = train_throughput.measure("ant", n, args.iterations)
      diayn_row = train_throughput.measure("ant", n, args.iterations, objective=diayn,
                                           raw_sps=task_row["raw_env_steps_per_s"])
      row = {"num_envs": n, "raw": task_row["raw_env_steps_per_s"],
             "task": task_row["train_env_steps_per_s"],
             "diayn": diayn_row["train_env_steps_per_s"],
             "diayn_first_step_s": diayn_row["start_to_first_step_s"]}
      rows.append(row)
      print(json.dumps(row), flush=True)
  mi = time_to_mi(args.mi_steps, args.mi_envs) if args.mi_steps else None
  if rows:
    for r in rows:
      r["diayn_per_raw"], r["diayn_per_task"] = r["diayn"] / r["raw"], r["diayn"] / r["task"]
    common.print_table("", rows, [
        ("num_envs", "num_envs", ""), ("raw env steps/s", "raw", ",.0f"),
        ("task PPO", "task", ",.0f"), ("DIAYN", "diayn", ",.0f"),
        ("DIAYN/raw", "diayn_per_raw", ".2f"), ("DIAYN/task", "diayn_per_task", ".2f"),
        ("start to first step s", "diayn_first_step_s", ".1f")], first="---:")
  else:
    print(f"\ndevice: {jax.devices()[0].device_kind}; jax {jax.__version__}")
  if mi:
    print(f"DIAYN ant {mi['num_envs']} envs: MI curve {[round(r['mi'], 3) for r in mi['rows']]}")
    print(f"time to MI >= {PAPER_MI}: {mi['time_to_paper_mi_s']} s "
          f"({mi['steps_to_paper_mi']} steps); total {mi['total_time_s']:.0f} s")
    out = os.environ.get("OUT")
    if out:
      with open(os.path.join(out, f"time_to_mi_{mi['num_envs']}.json"), "w") as f:
        json.dump(mi, f, indent=1)


if __name__ == "__main__":
  main()
