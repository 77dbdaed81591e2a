"""benchmarks/env_throughput.py: each ``--edits`` measures the env with those edits (e.g. the
humanoid with and without the observer "com" in one call), and bad edits are refused before
anything compiles."""

import argparse

import pytest

from tests.experiments import load_benchmark

env_throughput = load_benchmark("env_throughput")


def test_a_row_measures_the_env_with_its_edits():
  registered = env_throughput.measure("point", num_envs=2, steps=2)
  edited = env_throughput.measure("point", num_envs=2, steps=2,
                                  edits={"global_options.substeps": 3})
  assert (registered["substeps"], registered["edits"]) == (2, {})
  assert (edited["substeps"], edited["edits"]) == (3, {"global_options.substeps": 3})
  assert edited["obs_size"] == registered["obs_size"] == 4
  assert edited["env_steps_per_s"] > 0 and edited["ratio"] > 0


@pytest.mark.parametrize("text, says", [("[1]", "a JSON object of env edits"),
                                        ("{substeps: 3}", "not JSON")])
def test_edits_that_are_not_a_json_object_are_refused_with_what_is_valid(text, says):
  with pytest.raises(argparse.ArgumentTypeError, match=says):
    env_throughput.parse_edits(text)
