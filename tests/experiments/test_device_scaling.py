"""benchmarks/device_scaling.py: its arguments are read or refused by name, and a process that does
not see the device count it was started for refuses to measure rather than mislabel its row."""

import types

import pytest

from tests.experiments import load_benchmark

device_scaling = load_benchmark("device_scaling")


def test_env_params_and_device_counts_are_read_and_bad_ones_named():
  assert device_scaling.env_params(["num_legs=4", "step=original", "scale=0.5"]) == {
      "num_legs": 4, "step": "original", "scale": 0.5}
  with pytest.raises(SystemExit, match=r"--env-param takes KEY=VALUE, got 'num_legs'"):
    device_scaling.env_params(["num_legs"])
  assert device_scaling.device_counts("1,2,4") == [1, 2, 4]
  for bad in ("0,1", "1,1", "two", ""):
    with pytest.raises(SystemExit, match=r"--devices takes distinct counts of at least 1"):
      device_scaling.device_counts(bad)


def test_a_process_that_sees_another_device_count_refuses_to_measure():
  import jax
  seen = len(jax.local_devices())
  args = types.SimpleNamespace(env="point", env_param=[], num_envs=None, chunks=1, iterations=1,
                               seeds=1)
  with pytest.raises(SystemExit, match=rf"asked for {seen + 1} devices, this process sees {seen}"):
    device_scaling.measure(args, seen + 1)
