"""benchmarks/train_throughput.py: each ``--edits`` times training on the env with those edits (e.g.
the ant's contact solve with one Newton iteration and with four, in one call), and bad edits are
refused before anything compiles."""

import pytest

from tests.experiments import load_benchmark

train_throughput = load_benchmark("train_throughput")


def test_a_row_trains_the_env_with_its_edits():
  registered = train_throughput.measure("point", num_envs=64, iterations=1)
  edited = train_throughput.measure("point", num_envs=64, iterations=1,
                                    edits={"global_options.substeps": 3},
                                    raw_sps=registered["raw_env_steps_per_s"])
  assert (registered["substeps"], registered["edits"]) == (2, {})
  assert (edited["substeps"], edited["edits"]) == (3, {"global_options.substeps": 3})
  assert edited["train_env_steps_per_s"] > 0


def test_edits_that_are_not_a_json_object_are_refused(capsys, monkeypatch):
  monkeypatch.setattr("sys.argv", ["train_throughput.py", "--edits", "[1]"])
  with pytest.raises(SystemExit):
    train_throughput.main()
  assert "a JSON object of env edits" in capsys.readouterr().err
