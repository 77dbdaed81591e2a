"""benchmarks/energy_distance_time.py: its 'before' arm is the padded computation, giving the same
distances as ``metrics.energy_distance`` from more pairs, and bad input is refused by name."""

import sys

import jax
import numpy as np
import pytest

from blx.metrics import particle
from tests.experiments import load_benchmark

energy_distance_time = load_benchmark("energy_distance_time")


def test_the_padded_arm_gives_the_unpadded_distances():
  kx, ky, kw = jax.random.split(jax.random.PRNGKey(0), 3)
  x = jax.random.normal(kx, (30, 2))
  y = 1.5 + jax.random.normal(ky, (20, 2))
  weights = (jax.random.uniform(kw, (30,)) < 0.7).astype(np.float32)
  for w in (np.ones(30, np.float32), weights):
    now = particle.energy_distance(x, y, weights=w, block_size=16)
    before = energy_distance_time.padded_energy_distance(x, y, w, 16)
    assert float(now) > 0.5
    np.testing.assert_allclose(before, now, rtol=1e-5)
  # padded to 32 rows, 2 of them of weight 0, the 0/1 weights still give the kept samples' distance
  kept = np.asarray(weights) > 0
  np.testing.assert_allclose(energy_distance_time.padded_energy_distance(x, y, weights, 16),
                             particle.energy_distance(x[kept], y), rtol=1e-5)


@pytest.mark.parametrize("argv, message", [
    (["--dims", "3"], "--dims takes 1 and 2"),
    (["--dims", "a"], "--dims must be comma-separated ints"),
    (["--repeats", "0"], "--repeats must be at least 1"),
])
def test_bad_input_is_named(monkeypatch, capsys, argv, message):
  monkeypatch.setattr(sys, "argv", ["energy_distance_time.py", *argv])
  with pytest.raises(SystemExit) as exit_:
    energy_distance_time.main()
  assert exit_.value.code == 2 and message in capsys.readouterr().err
