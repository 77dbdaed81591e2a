"""Bad descs raise ValueError naming the offending key or value and the valid choices."""

from __future__ import annotations

import copy

import pytest

from blx import envs

BASE = dict(components=dict(agent1=dict(component="point"), ball=dict(component="singleton")))


def _with(**changes):
  desc = copy.deepcopy(BASE)
  for path, value in changes.items():
    node = desc
    keys = path.split("__")
    for k in keys[:-1]:
      node = node[k]
    node[keys[-1]] = value
  return desc


@pytest.mark.parametrize("desc, pattern", [
    (_with(components__agent1__component="spider"), r"unknown component 'spider'.*'ant'"),
    (_with(components__ball__observers=["qp", "actuator"]),
     r"components.ball.observers\[1\]: component 'ball' has no motors"),
    (_with(components__agent1__observers=["root_everything"]),
     r"unknown observer 'root_everything'.*root_z_joints"),
    (_with(components__agent1__reward_fns={"r": {"reward_type": "happiness"}}),
     r"components.agent1.reward_fns.r: unknown reward_type 'happiness'.*root_goal"),
    (_with(components__agent1__colour="red"), r"components.agent1: unknown key\(s\) \['colour'\].*"
                                              r"component_params"),
    (_with(edgez={}), r"desc: unknown key\(s\) \['edgez'\].*edges"),
    (_with(edges={"ball__agent1": {}}), r"'ball__agent1'.*sorted.*'agent1__ball'"),
    (_with(edges={"agent1_ball": {}}), r"invalid edge key 'agent1_ball'.*joined by '__'"),
    (_with(edges={"agent1__cat": {}}), r"unknown component\(s\) \['cat'\]"),
    (_with(edges={"agent1__ball": {"collide_type": "some"}}), r"collide_type.*'full', 'root'"),
    (_with(components__ball__component_params={"size": "big"}),
     r"parameter 'size' must be float, got 'big'"),
    (_with(components__ball__component_params={"colour": 1}),
     r"unknown parameter\(s\) \['colour'\].*'size'"),
    (_with(components__agent1__component="pro_ant", components__agent1__component_params={
        "num_legs": 1}), r"num_legs=1 is out of range; valid values are 2\.\.16"),
    (_with(components__agent1__component="pro_ant", components__agent1__component_params={
        "num_legs": 4.5}), r"'num_legs' must be int"),
    (_with(global_options={"substepz": 3}), r"global_options: unknown key\(s\) \['substepz'\]"),
    (_with(components__agent1__reward_fns={"g": {"reward_type": "root_goal", "target": 1}}),
     r"unknown key\(s\) \['target'\].*target_goal"),
    (_with(edges={"agent1__ball": {"reward_fns": {"g": {"reward_type": "root_goal"}}}}),
     r"'root_goal' cannot be used on an edge"),
    (_with(edges={"agent1__ball": {"extra_observers": [{"observer_type": "root_angle"}]}}),
     r"unknown observer_type 'root_angle'.*root_vec"),
    (_with(components__ball__pos=(0.0, float("nan"), 0.0)), r"pos: expected 3 finite numbers"),
    (_with(global_options={"timestep": float("inf")}), r"global_options.timestep: must be a "
                                                       r"positive number, got inf"),
    (_with(global_options={"gravity": (0, 0, float("-inf"))}), r"gravity: expected 3 finite"),
    (_with(global_options={"substeps": 10**12}), r"substeps: must be an int in 1\.\.1000"),
    (_with(edges={"agent1__ground": {"reward_fns": {"d": {"reward_type": "root_dist"}}}}),
     r"edges.agent1__ground: ground has no root; only collide_type may be set"),
])
def test_bad_desc_raises_naming_the_problem(desc, pattern):
  with pytest.raises(ValueError, match=pattern):
    envs.create(desc=desc)


def test_unknown_env_name_lists_the_valid_ones():
  with pytest.raises(ValueError, match=r"unknown env 'ant_dance'.*'ant_push'"):
    envs.create("ant_dance")


def test_unknown_env_param_is_rejected():
  with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['legs'\].*num_legs"):
    envs.create("pro_ant_run", legs=6)


@pytest.mark.parametrize("params, message", [
    (dict(target="abc"), r"env 'point_goal': parameter 'target' must be tuple, got 'abc' \(str\)"),
    (dict(target=True), r"parameter 'target' must be tuple, got True"),
])
def test_env_param_of_the_wrong_type_is_named(params, message):
  # A string would otherwise be split into characters and fail later as "could not convert 'a'".
  with pytest.raises(ValueError, match=message):
    envs.create("point_goal", **params)
  with pytest.raises(ValueError, match=r"parameter 'num_legs' must be int, got 4.5"):
    envs.create("pro_ant_run", num_legs=4.5)


def test_bad_edit_path_names_the_missing_key():
  with pytest.raises(ValueError, match=r"no key 'cap9'.*\['agent1', 'cap1'\]"):
    envs.create("ant_push", edits={"components.cap9.pos": (0, 0, 0)})


def test_unknown_named_index_set_lists_the_valid_ones():
  env = envs.create("point")
  with pytest.raises(ValueError, match=r"unknown name 'speed'.*'vel_xy'"):
    env.obs_indices("speed")


def test_register_component_and_env():
  from blx.envs import components as comps
  envs.register_component("test_tiny_ball", lambda radius=0.3: comps.singleton(size=radius))
  envs.register_env("test_point_and_ball", dict(components=dict(
      agent1=dict(component="point"),
      ball=dict(component="test_tiny_ball", component_params=dict(radius=0.2)))))
  assert "test_tiny_ball" in envs.list_components()
  env = envs.create("test_point_and_ball")
  assert "ball/root_pos" in env.obs_layout
  with pytest.raises(ValueError, match="already registered"):
    envs.register_env("test_point_and_ball", {})
