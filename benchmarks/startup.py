"""Start-up of ``blx train``: seconds from process start to the first finished training chunk,
without the compilation cache, with a cold cache and with a warm one (issue: first step <= 20 s
cold, <= 10 s on a second run).

    python benchmarks/startup.py [--env ant] [--objective diayn] [--steps N]
                                 [--config num_envs=2048 ...] [--repeats 1]
                                 [--compile-modes serial,parallel]

Each arm is a fresh ``python -m blx.experiments.cli train`` process (so Python and JAX import
costs are in every figure), with ``BLX_COMPILATION_CACHE`` set to ``off``, then to an empty
directory (cold), then to that same directory again (warm). ``--compile-modes`` runs the arm
without the cache once per mode (``BLX_PARALLEL_COMPILE`` 0 for ``serial``, 1 for ``parallel``;
``default`` leaves it unset), side by side in one call; the cold and warm arms take the last mode.
Printed per arm: seconds to the first progress line (compilation plus the first chunk), the
compile seconds the run reports, and the whole command's wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


MODES = {"serial": "0", "parallel": "1", "default": None}


def run_once(args, cache: str, out: str, mode: str = "default") -> dict:
  cmd = [sys.executable, "-m", "blx.experiments.cli", "train", "--env", args.env, "--objective",
         args.objective, "--out", out]
  if args.steps:
    cmd += ["--steps", str(args.steps)]
  for item in args.config or []:
    cmd += ["--config", item]
  env = {**os.environ, "BLX_COMPILATION_CACHE": cache, "PYTHONUNBUFFERED": "1",
         "PYTHONPATH": os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")])}
  env.pop("BLX_PARALLEL_COMPILE", None)
  if MODES[mode] is not None:
    env["BLX_PARALLEL_COMPILE"] = MODES[mode]
  start = time.time()
  proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                          env=env)
  first = None
  tail = []
  for line in proc.stderr:
    tail = (tail + [line])[-20:]
    if first is None and re.match(r"^(\r\x1b\[2K)?\[[#.]+\] [\d,]+/[\d,]+ steps", line):
      first = time.time() - start
  proc.wait()
  wall = time.time() - start
  if proc.returncode != 0:
    raise SystemExit(f"startup: {' '.join(cmd)} failed:\n{''.join(tail)}")
  with open(os.path.join(out, "metrics.csv")) as f:
    header = f.readline().strip().split(",")
    row = f.readline().strip().split(",")
  compile_s = float(row[header.index("compile_seconds")]) if "compile_seconds" in header else None
  return {"first_chunk_s": first, "compile_s": compile_s, "wall_s": wall}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--env", default="point")
  parser.add_argument("--objective", default="diayn")
  parser.add_argument("--steps", type=int, default=None)
  parser.add_argument("--config", action="append", metavar="KEY=VALUE")
  parser.add_argument("--repeats", type=int, default=1)
  parser.add_argument("--compile-modes", default="default",
                      help=f"comma list of {sorted(MODES)}: how the arm without the cache compiles "
                      "(one arm each); the cached arms take the last")
  args = parser.parse_args()
  modes = args.compile_modes.split(",")
  bad = [m for m in modes if m not in MODES]
  if bad:
    parser.error(f"--compile-modes: {bad} not among {sorted(MODES)}")
  import jax
  results = []
  with tempfile.TemporaryDirectory() as tmp:
    for repeat in range(args.repeats):
      cache = os.path.join(tmp, f"cache{repeat}")  # empty: the "cold" arm fills it
      arms = [(f"cache off, {mode} compile", "off", mode) for mode in modes]
      arms += [(f"cold cache, {modes[-1]} compile", cache, modes[-1]),
               (f"warm cache, {modes[-1]} compile", cache, modes[-1])]
      for i, (name, setting, mode) in enumerate(arms):
        r = run_once(args, setting, os.path.join(tmp, f"run{repeat}_{i}"), mode)
        results.append({"arm": name, **r})
        print(json.dumps(results[-1]), flush=True)
  print(f"\nblx train --env {args.env} --objective {args.objective} "
        f"{' '.join('--config ' + c for c in args.config or [])}; jax {jax.__version__}, "
        f"{jax.devices()[0].platform}")
  print("| arm | to the first chunk (s) | compile reported (s) | whole command (s) |")
  print("| --- | ---: | ---: | ---: |")
  for r in results:
    print(f"| {r['arm']} | {r['first_chunk_s']:.1f} | {r['compile_s']:.1f} | {r['wall_s']:.1f} |")


if __name__ == "__main__":
  main()
