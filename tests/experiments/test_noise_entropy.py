"""benchmarks/noise_entropy.py: bad input is refused before anything runs, naming the flag or the
edit that is wrong."""

import sys

import pytest

from tests.experiments import load_benchmark

noise_entropy = load_benchmark("noise_entropy")


@pytest.mark.parametrize("argv, message", [
    (["--env-edits", "{x"], "--env-edits: not JSON"),
    (["--env-edits", "[1]"], "--env-edits: a JSON object of env edits"),
    (["--env", "point", "--env-edits", '{"nope.x": 1}'], "edits: 'nope.x': no key 'nope'"),
])
def test_bad_input_is_named(monkeypatch, capsys, argv, message):
  monkeypatch.setattr(sys, "argv", ["noise_entropy.py", *argv])
  with pytest.raises(SystemExit) as exit_:
    noise_entropy.main()
  assert exit_.value.code == 2 and message in capsys.readouterr().err
