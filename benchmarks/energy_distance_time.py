"""What session 35's unpadded ``metrics.energy_distance`` saves on a device: the D-min evaluation's
two energy distances, vmapped over seeds, as ``blx.metrics`` computes them now and as it did before
(every input shorter than ``block_size`` padded to one whole block with states of weight 0).

    python benchmarks/energy_distance_time.py [--seeds 10] [--episodes 10] [--samples 50]
        [--target 250] [--dims 1,2] [--block-size 1024] [--repeats 20]

The shapes are the final D-min evaluation's (``metrics.dmin_evaluator``: 10 episodes, every 10th
of the last 500 steps, so 500 states per seed, against the 250 samples of the target
``objectives.multimode_gaussian`` draws); the states are Gaussian noise, since the cost does not
depend on the values. The evaluation computes two distances per seed (``eval/energy_distance`` and
``eval/energy_distance_braxlines``, the second with 0/1 weights), both timed here, in one jitted
call over all seeds. Both arms are checked to give the same distances before they are timed (which
compiles them). The table gives the median wall milliseconds of a call and its ratio to the
unpadded arm's, measured in the same process; the last line is JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx.metrics import particle  # noqa: E402
from blx.objectives import multimode_gaussian  # noqa: E402


def padded_length(n: int, block_size: int) -> int:
  """``n`` rounded up to a whole number of ``block_size`` blocks: an input's length as the
  energy distance padded it before session 35."""
  return -(-n // block_size) * block_size


def padded_energy_distance(x, y, weights, block_size):
  """The energy distance as ``blx.metrics`` computed it before session 35: ``x`` and ``y`` each
  padded to a whole number of ``block_size`` blocks (``padded_length``), padding weighing 0."""
  def whole(a, w):
    pad = padded_length(a.shape[0], block_size) - a.shape[0]
    return jnp.pad(a, ((0, pad), (0, 0))), jnp.pad(w.astype(a.dtype), (0, pad))

  xp, wx = whole(x, weights)
  yp, wy = whole(y, jnp.ones(y.shape[0]))
  mpd = lambda a, b, wa, wb: particle._mean_pairwise_distance(a, b, block_size, wa, wb)
  return 2.0 * mpd(xp, yp, wx, wy) - mpd(xp, xp, wx, wx) - mpd(yp, yp, wy, wy)


def evaluation(distance):
  """A jitted ``(x [seeds, N, D], valid [seeds, N], target [M, D]) -> [seeds, 2]``: per seed the
  evaluation's two distances, unweighted and with the 0/1 weights ``valid``."""
  def one(x, valid, target):
    return jnp.stack([distance(x, target, jnp.ones(x.shape[0])), distance(x, target, valid)])
  return jax.jit(jax.vmap(one, in_axes=(0, 0, None)))


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--seeds", type=int, default=10)
  parser.add_argument("--episodes", type=int, default=10)
  parser.add_argument("--samples", type=int, default=50, help="scored states per episode")
  parser.add_argument("--target", type=int, default=250, help="target samples")
  parser.add_argument("--dims", default="1,2", help="comma-separated feature dimensions (1 or 2)")
  parser.add_argument("--block-size", type=int, default=1024)
  parser.add_argument("--repeats", type=int, default=20)
  args = parser.parse_args()
  try:
    dims = [int(d) for d in args.dims.split(",")]
  except ValueError:
    parser.error(f"--dims must be comma-separated ints, got {args.dims!r}")
  if not dims or any(d not in (1, 2) for d in dims):
    parser.error(f"--dims takes 1 and 2 (the default target's dimensions), got {args.dims!r}")
  for flag, value in (("--seeds", args.seeds), ("--episodes", args.episodes),
                      ("--samples", args.samples), ("--target", args.target),
                      ("--block-size", args.block_size), ("--repeats", args.repeats)):
    if value < 1:
      parser.error(f"{flag} must be at least 1, got {value}")

  now = lambda x, y, w: particle.energy_distance(x, y, weights=w, block_size=args.block_size)
  before = lambda x, y, w: padded_energy_distance(x, y, w, args.block_size)
  arms = {"unpadded (now)": (evaluation(now), False), "padded (before)": (evaluation(before), True)}
  n = args.episodes * args.samples
  rows = []
  for dim in dims:
    target = jnp.asarray(multimode_gaussian(2, scale=5.0, dim=dim,
                                            num_samples=args.target).samples)
    keys = jax.random.split(jax.random.PRNGKey(dim), args.repeats + 1)
    draws = [(jax.random.normal(k, (args.seeds, n, dim)),
              (jax.random.uniform(k, (args.seeds, n)) < 0.9).astype(jnp.float32)) for k in keys]
    values = {name: np.asarray(fn(*draws[0], target)) for name, (fn, _) in arms.items()}
    first, second = values.values()
    if not np.allclose(first, second, rtol=1e-4, atol=1e-5):
      raise SystemExit(f"the two arms disagree at D = {dim}: {first} vs {second}")
    for name, (fn, padded) in arms.items():
      _, times = common.time_calls(fn, lambda i: (*draws[i], target), args.repeats)
      a, b = ((padded_length(n, args.block_size), padded_length(args.target, args.block_size))
              if padded else (n, args.target))
      # per seed, each of the two distances sums a x b, a x a and b x b pairs
      rows.append({"dim": dim, "arm": name, "pairs": 2 * (a * b + a * a + b * b),
                   "median_ms": 1e3 * float(np.median(times))})
    rows[-2]["ratio"] = 1.0
    rows[-1]["ratio"] = rows[-1]["median_ms"] / rows[-2]["median_ms"]
  common.print_table(f"; {args.seeds} seeds x 2 distances, {n} states against {args.target}",
                     rows, [("D", "dim", "d"), ("arm", "arm", "s"),
                            ("pairs per seed", "pairs", ","), ("median ms", "median_ms", ".3f"),
                            ("time / now's", "ratio", ".2f")])
  print(json.dumps({"device": jax.devices()[0].device_kind, "jax": jax.__version__,
                    "seeds": args.seeds, "states": n, "target": args.target,
                    "block_size": args.block_size, "repeats": args.repeats, "rows": rows}))


if __name__ == "__main__":
  main()
