"""The bad-input suite: every number and name a user gives blx (objective options, PPO config,
env descs, episode settings) is checked where it enters, and a bad one is a ``ValueError`` whose
message names it. The tables are generated per field, so a new option or field with no check shows
up here as a failure. The CLI's, sweeps' and run directories' bad inputs are in
``tests/experiments/test_cli.py``; unknown names in ``tests/test_options.py``."""

from __future__ import annotations

import copy
import dataclasses
import inspect

import pytest

from blx import envs, objectives, training
from blx.objectives import presets

NAN, INF = float("nan"), float("inf")
NOT_NUMBERS = ["x", True, None]

# Bad values per objective option, by what the option is.
OPTION_BAD = {
    "obs_scale": [NAN, INF, -INF, 0.0, -1.0, *NOT_NUMBERS],
    "logits_clip": [NAN, INF, 0.0, -1.0, *NOT_NUMBERS],
    "gradient_penalty_weight": [NAN, INF, -1.0, *NOT_NUMBERS],
    "env_reward_multiplier": [NAN, INF, -INF, *NOT_NUMBERS],
    "num_skills": [0, 1, -1, 1.5, True, "3", 10**12],
    "num_modes": [0, -1, 1.5, True, "2"],
    "target_seed": [-1, 1.5, True, "0", 2**40],
    "spectral_norm": ["yes", 1, None],
    "normalize_obs": ["yes", 1],
    "include_action": ["yes", 1],
    "balance_data": ["yes", 1],
    "clip_loss_logits": ["yes", 1],
    "hidden": [(0,), "32", (1.5,), (-4, 4), 32],
    "spectral_iteration": ["bogus", 1],
    "obs_indices": [(), (-1,), (1.5,), {1: 2}, "vel_xy", (0, 0), 1.5],
    "target": ["abc", 5],
}


def _option_cases():
  for name in objectives.list_objectives():
    accepted = inspect.signature(presets._preset(name)).parameters
    for option, values in OPTION_BAD.items():
      if option in accepted:
        for value in values:
          yield pytest.param(name, option, value, id=f"{name}-{option}={value!r}")


@pytest.mark.parametrize("name, option, value", list(_option_cases()))
def test_bad_objective_options_are_named(name, option, value):
  options = {"obs_indices": (0, 1)} if "obs_indices" in presets.options_of(name) else {}
  options[option] = value
  with pytest.raises(ValueError) as info:
    objectives.make(name, **options)
  assert option in str(info.value), str(info.value)


def test_every_objective_option_has_bad_values_above():
  untested = {o for n in objectives.list_objectives() for o in presets.options_of(n)
              } - set(OPTION_BAD) - {"env"}
  assert not untested, f"options without bad-input cases: {sorted(untested)}"


# Bad values per PPOConfig field, by the field's kind.
COUNTS = [0, -1, 1.5, True, "8", 2**40]
REALS = [NAN, INF, -INF, *NOT_NUMBERS]
PPO_BAD = {
    **{f: COUNTS for f in ("num_timesteps", "num_envs", "unroll_length", "batch_size",
                           "num_minibatches", "num_updates_per_batch", "num_evals",
                           "num_eval_envs")},
    "learning_rate": REALS + [0.0, -1e-3],
    "entropy_cost": REALS + [-0.1],
    "discounting": REALS + [1.5, -0.1],
    "gae_lambda": REALS + [1.5, -0.1],
    "clipping_epsilon": REALS + [0.0, -0.2],
    "reward_scaling": REALS + [0.0],
    "max_grad_norm": [NAN, INF, 0.0, -1.0, "x", True],
    "normalize_observations": ["yes", 1, None],
    "normalize_advantage": ["yes", 1, None],
    "normalize_latent": ["yes", 1, None],
    "staggered_starts": ["yes", 1, "auto"],
    "checkpoint_env_state": ["no", 0, None],
    "eval_actions": ["greedy", "Mean", "", None, 1, True],
    "policy_hidden": [(), (0,), "32", (1.5,), (32, -1), 32],
    "value_hidden": [(), (0,), "32", (1.5,), (32, -1), 32],
}


def _ppo_cases():
  for field, values in PPO_BAD.items():
    for value in values:
      yield pytest.param(field, value, id=f"{field}={value!r}")


@pytest.mark.parametrize("field, value", list(_ppo_cases()))
def test_bad_ppo_config_is_named(field, value):
  with pytest.raises(ValueError) as info:
    training.PPOConfig().replace(**{field: value})
  assert field in str(info.value), str(info.value)


def test_every_ppo_field_has_bad_values_above():
  assert {f.name for f in dataclasses.fields(training.PPOConfig)} == set(PPO_BAD)


BASE = dict(components=dict(agent1=dict(component="point"), ball=dict(component="singleton")))
GOAL = dict(components=dict(agent1=dict(component="point", reward_fns={
    "g": dict(reward_type="root_goal", sdcomp="vel")}), ball=dict(component="singleton")))


def _with(path: str, value, base=BASE) -> dict:
  desc = copy.deepcopy(base)
  node = desc
  keys = path.split(".")
  for key in keys[:-1]:
    node = node.setdefault(key, {})
  node[keys[-1]] = value
  return desc


def _desc_cases():
  """(desc, what the message must name)."""
  for v in [NAN, INF, -INF, "x", True, None]:
    yield _with("components.agent1.component_params", {"gear": v}), "gear"
    yield _with("components.agent1.component_params", {"damping": v}), "damping"
    yield _with("components.ball.component_params", {"size": v}), "size"
    yield _with("global_options.timestep", v), "timestep"
    yield _with("global_options.reset_noise_scale", v), "reset_noise_scale"
    yield _with("global_options.substeps", v), "substeps"
    yield _with("components.agent1.reward_fns.g.scale", v, GOAL), "scale"
    yield _with("components.agent1.reward_fns.g.offset", v, GOAL), "offset"
    yield _with("components.agent1.reward_fns.g.done_bonus", v, GOAL), "done_bonus"
    yield _with("components.agent1.reward_fns.c", dict(reward_type="constant", value=v)), "value"
    yield _with("components.agent1.term_params", {"z_offset": v}), "z_offset"
    yield _with("components.ball.pos", (0.0, v, 0.0)), "pos"
    yield _with("components.ball.quat", (1.0, v, 0.0, 0.0)), "quat"
    yield _with("global_options.gravity", (0.0, v, -9.8)), "gravity"
  for v in [-1.0, 0.0]:
    yield _with("components.agent1.component_params", {"gear": v}), "gear"
    yield _with("components.ball.component_params", {"size": v}), "size"
    yield _with("global_options.timestep", v), "timestep"
  yield _with("components.agent1.component_params", {"damping": -1.0}), "damping"
  yield _with("global_options.reset_noise_scale", -1.0), "reset_noise_scale"
  yield _with("global_options.substeps", 0), "substeps"
  yield _with("global_options.substeps", 2.5), "substeps"
  yield _with("components.ball.pos", (0.0, 0.0)), "pos"
  yield _with("components.ball.pos", "origin"), "pos"
  yield _with("global_options.gravity", (0, -9.8)), "gravity"
  yield _with("components.ball.component_params", {"size": (0.1,)}), "size"
  yield _with("components.ball.component_params", {"collider_type": "cube"}), "collider_type"
  yield _with("components.ball.frozen", "yes"), "frozen"
  octopus = dict(components=dict(agent1=dict(component="octopus")))
  yield _with("components.agent1.component_params", {"all_collide": "yes"}, octopus), "all_collide"
  yield _with("components.ball.collide", 0), "collide"
  yield _with("components.agent1.observers", "root_vec"), "observers"
  yield _with("components.agent1.reward_fns.g.sdcomp", "speed", GOAL), "sdcomp"
  yield _with("components.agent1.reward_fns.g.target_goal", (NAN, 0.0), GOAL), "target_goal"
  yield _with("components.agent1.reward_fns.g.target_goal", "far", GOAL), "target_goal"
  yield {"components": {}}, "components"
  yield {"components": ["point"]}, "components"
  yield _with("edges", ["agent1__ball"]), "edges"


@pytest.mark.parametrize("desc, named", [pytest.param(d, n, id=f"{n}-{i}")
                                         for i, (d, n) in enumerate(_desc_cases())])
def test_bad_desc_numbers_and_shapes_are_named(desc, named):
  with pytest.raises(ValueError) as info:
    envs.create(desc=desc)
  assert named in str(info.value), str(info.value)


@pytest.mark.parametrize("setting", ["episode_length", "action_repeat"])
@pytest.mark.parametrize("value", [0, -1, 1.5, True, "100", 2**31])
def test_bad_episode_settings_are_named(setting, value):
  with pytest.raises(ValueError, match=setting):
    envs.create("point", **{setting: value})
