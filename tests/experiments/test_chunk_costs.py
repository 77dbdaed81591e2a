"""benchmarks/chunk_costs.py: each part is compiled by a first call, then timed on fresh arguments."""

import importlib.util
import pathlib
import sys

import jax.numpy as jnp

_DIR = pathlib.Path(__file__).resolve().parents[2] / "benchmarks"
sys.path.insert(0, str(_DIR))  # the script imports common and time_to_quality beside it
_spec = importlib.util.spec_from_file_location("chunk_costs", _DIR / "chunk_costs.py")
chunk_costs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(chunk_costs)


def test_the_first_call_is_kept_apart_and_every_timed_call_gets_its_own_arguments():
  seen = []

  def fn(i):
    seen.append(i)
    return jnp.asarray(i)

  first, times = chunk_costs.time_calls(fn, lambda i: (i,), repeats=3)
  assert seen == [0, 1, 2, 3]  # one untimed first call (the compile), then 3 timed ones
  assert len(times) == 3 and first >= 0 and all(t >= 0 for t in times)
