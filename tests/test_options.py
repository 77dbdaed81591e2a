"""Every place that takes options by name rejects an unknown one with the same sentence, naming it
and the valid names (blx.options.check_names)."""

from __future__ import annotations

import re

import pytest

from blx import envs, objectives, training

SENTENCE = r"unknown (\w+)\(s\) \['typo'\]; valid \1s are \[.*'{valid}'.*\]"


@pytest.mark.parametrize("build, valid", [
    (lambda: envs.get_desc("pro_ant_run", typo=1), "num_legs"),  # env parameter
    (lambda: envs.create("ant", edits={"components.agent1.component_params": {"typo": 1}}),
     "limit_damping"),  # component parameter
    (lambda: envs.create(desc={"components": {"p": {"component": "point"}}, "typo": 1}),
     "components"),  # desc key
    (lambda: envs.create(desc={"components": {"p": {"component": "point", "reward_fns": {  # reward
        "g": {"reward_type": "root_goal", "sdcomp": "vel", "typo": 1}}}}}), "target_goal"),
    (lambda: objectives.make("diayn", typo=1), "num_skills"),  # objective option
    (lambda: training.PPOConfig().replace(typo=1), "num_envs"),  # PPO config key
])
def test_unknown_names_are_rejected_in_one_sentence(build, valid):
  with pytest.raises(ValueError) as info:
    build()
  assert re.search(SENTENCE.format(valid=valid), str(info.value)), str(info.value)


def test_seeds_are_checked_once_for_train_the_cli_and_sweeps():
  import numpy as np
  assert training.check_seeds(np.arange(3)) == (0, 1, 2)  # numpy (and jax) integer scalars too
  for seeds, message in ([[0, 0], "repeats a seed"], [[], "non-empty list"], ["01", "non-empty"],
                         [[1.0], r"\[1.0\] are not seeds"], [[True], "are not seeds"],
                         [[2**31], "0..2\\*\\*31 - 1"]):
    with pytest.raises(ValueError, match=message):
      training.check_seeds(seeds)
