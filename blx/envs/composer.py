"""The composer: a desc (plain dict) -> a validated, deterministic MJCF scene.

A desc, as in the Braxlines paper's appendix::

    dict(
        components=dict(
            agent1=dict(component="pro_ant", component_params=dict(num_legs=6)),
            cap1=dict(component="singleton", component_params=dict(size=0.5), pos=(1, 0, 0),
                      reward_fns=dict(goal=dict(reward_type="root_goal", sdcomp="vel",
                                                target_goal=(4, 0, 0)))),
        ),
        edges=dict(
            agent1__cap1=dict(extra_observers=[dict(observer_type="root_vec")],
                              reward_fns=dict(dist=dict(reward_type="root_dist"))),
        ),
    )

Component keys: ``component``, ``component_params``, ``pos``, ``quat`` (wxyz), ``reward_fns``,
``observers`` (replaces the component's defaults), ``frozen`` (weld every body to the world),
``collide`` (False: no contacts with anything), ``term_params`` (``z_offset`` for height rules).
Edge keys (edge name = the two component names sorted and joined by ``__``; ``ground`` may be one):
``collide_type`` ('full': all collider pairs, the default; 'root': root colliders only; None: no
contact), ``extra_observers``, ``reward_fns``. ``global_options``: see :data:`GLOBAL_OPTIONS`.
``agent_groups`` makes the scene multi-agent (which agent claims which reward terms and drives
which actuators): see ``blx.envs.agents``.

Contacts are explicit ``<pair>`` elements and every geom has contype = conaffinity = 0, so MJX only
tests the pairs that matter (feet against floor, agent against object). Pair friction is the smaller
of the two sides' friction.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from typing import Any, Mapping

from blx.envs import components as components_lib
from blx.envs.agents import check_agent_groups
from blx.envs.components import GROUND, ComponentSpec
from blx.envs.mjcf import Element, walk
from blx.options import check_names, finite_number

__all__ = ["Scene", "compose", "apply_edits", "GLOBAL_OPTIONS", "TOP_KEYS", "COMPONENT_KEYS",
           "EDGE_KEYS"]

TOP_KEYS = ("components", "edges", "global_options", "add_ground", "agent_groups")
COMPONENT_KEYS = ("component", "component_params", "pos", "quat", "reward_fns", "observers",
                  "frozen", "collide", "term_params")
EDGE_KEYS = ("collide_type", "extra_observers", "reward_fns")
COLLIDE_TYPES = ("full", "root", None)

# Physics defaults tuned for MJX speed: Newton with one iteration and four line-search steps,
# Euler damping off (MJX practice); 5 substeps of 10 ms make one 50 ms env step.
GLOBAL_OPTIONS: dict[str, Any] = dict(
    timestep=0.01,
    substeps=5,
    solver="Newton",
    iterations=1,
    ls_iterations=4,
    gravity=(0.0, 0.0, -9.81),
    reset_noise_scale=0.0,
    # Brax v1's humanoid reset ends with one control step of actions drawn from U[0, 0.5) per
    # motor (its only randomness); reset_actions=0.5 does the same here. 0: no such step.
    reset_actions=0.0,
)
SOLVERS = ("Newton", "CG", "PGS")


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
  """A composed scene: the MJCF string and what is needed to resolve names after compiling."""

  xml: str
  desc: dict
  specs: dict[str, ComponentSpec]   # by component name, sorted; ground excluded
  options: dict[str, Any]


def _err(where: str, message: str) -> ValueError:
  return ValueError(f"{where}: {message}")


def _check_keys(where: str, mapping: Any, valid: tuple[str, ...]) -> None:
  if not isinstance(mapping, Mapping):
    raise _err(where, f"expected a dict, got {mapping!r}")
  check_names(where, mapping, valid, "key")


def _vector(where: str, value: Any, size: int) -> tuple[float, ...]:
  if (not isinstance(value, (tuple, list)) or len(value) != size
      or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                 for v in value)):
    raise _err(where, f"expected {size} finite numbers, got {value!r}")
  return tuple(float(v) for v in value)


MAX_STEPS_PER_CALL = 1000  # substeps per env step, solver iterations: more is a typo, not a setting


def _check_options(options: Any) -> dict[str, Any]:
  _check_keys("global_options", options, tuple(GLOBAL_OPTIONS))
  merged = {**GLOBAL_OPTIONS, **options}
  for key in ("timestep", "reset_noise_scale", "reset_actions"):
    if (not isinstance(merged[key], (int, float)) or isinstance(merged[key], bool)
        or not math.isfinite(merged[key]) or merged[key] < 0 or (
        key == "timestep" and merged[key] == 0)):
      raise _err(f"global_options.{key}", f"must be a {'positive' if key == 'timestep' else 'non-negative'} number, got {merged[key]!r}")
  if merged["reset_actions"] > 1:
    raise _err("global_options.reset_actions", "the reset step's actions are U[0, reset_actions) "
               f"and actions lie in [-1, 1]: give a number in [0, 1], got "
               f"{merged['reset_actions']!r}")
  for key in ("substeps", "iterations", "ls_iterations"):
    if (not isinstance(merged[key], int) or isinstance(merged[key], bool)
        or not 1 <= merged[key] <= MAX_STEPS_PER_CALL):
      raise _err(f"global_options.{key}", f"must be an int in 1..{MAX_STEPS_PER_CALL}, got "
                 f"{merged[key]!r}")
  if merged["solver"] not in SOLVERS:
    raise _err("global_options.solver", f"unknown solver {merged['solver']!r}; valid solvers are "
               f"{list(SOLVERS)}")
  merged["gravity"] = _vector("global_options.gravity", merged["gravity"], 3)
  return merged


def _check_name(name: Any) -> None:
  if (not isinstance(name, str) or not name or "__" in name or "/" in name or name == GROUND
      or not name.replace("_", "a").isalnum()):
    raise ValueError(f"components: invalid component name {name!r}; names are letters, digits and "
                     f"single underscores, not {GROUND!r}")


def _prefix(bodies: tuple[Element, ...], prefix: str, frozen: bool) -> list[Element]:
  out = []
  for body in bodies:
    body = copy.deepcopy(body)
    for el in walk(body):
      if frozen:
        el.children = [c for c in el.children if c.tag not in ("joint", "freejoint")]
      if "name" in el.attrs:
        el.attrs["name"] = f"{prefix}/{el.attrs['name']}"
      if el.tag == "geom":
        el.attrs["contype"] = 0
        el.attrs["conaffinity"] = 0
    out.append(body)
  return out


def compose(desc: Mapping[str, Any]) -> Scene:
  """Validates ``desc`` and renders its scene to a deterministic MJCF string."""
  _check_keys("desc", desc, TOP_KEYS)
  desc = copy.deepcopy(dict(desc))
  comps = desc.get("components")
  if not isinstance(comps, Mapping) or not comps:
    raise ValueError("desc: 'components' must be a non-empty dict of {name: component desc}")
  options = _check_options(desc.get("global_options", {}))
  add_ground = desc.get("add_ground", True)
  if not isinstance(add_ground, bool):
    raise ValueError(f"desc.add_ground: must be a bool, got {add_ground!r}")

  specs: dict[str, ComponentSpec] = {}
  for name in sorted(comps):
    _check_name(name)
    where = f"components.{name}"
    comp = comps[name]
    _check_keys(where, comp, COMPONENT_KEYS)
    if "component" not in comp:
      raise _err(where, f"missing 'component'; valid components are "
                 f"{components_lib.list_components()[:-1]}")
    if not isinstance(comp["component"], str):
      raise _err(f"{where}.component", f"must be a registered name, got {comp['component']!r}")
    specs[name] = components_lib.make_component(comp["component"],
                                                comp.get("component_params"), where)
    for key in ("frozen", "collide"):
      if not isinstance(comp.get(key, key == "collide"), bool):
        raise _err(f"{where}.{key}", f"must be a bool, got {comp[key]!r}")
    if "pos" in comp:
      comp["pos"] = _vector(f"{where}.pos", comp["pos"], 3)
    if "quat" in comp:
      comp["quat"] = _vector(f"{where}.quat", comp["quat"], 4)
    _check_keys(f"{where}.term_params", comp.get("term_params", {}), ("z_offset",))
    if "z_offset" in comp.get("term_params", {}):
      finite_number(f"{where}.term_params.z_offset", comp["term_params"]["z_offset"])
    for key in ("reward_fns",):
      if not isinstance(comp.get(key, {}), Mapping):
        raise _err(f"{where}.{key}", f"must be a dict of {{name: term desc}}, got {comp[key]!r}")
    if "observers" in comp and not isinstance(comp["observers"], (list, tuple)):
      raise _err(f"{where}.observers", f"must be a list of observers, got {comp['observers']!r}")

  participants = sorted(specs) + ([GROUND] if add_ground else [])
  edges = desc.get("edges", {}) or {}
  if not isinstance(edges, Mapping):
    raise ValueError(f"desc.edges: must be a dict of {{'a__b': edge desc}}, got {edges!r}")
  for key, edge in edges.items():
    parts = key.split("__") if isinstance(key, str) else []
    if len(parts) != 2 or not all(parts):
      raise ValueError(f"edges: invalid edge key {key!r}; an edge key is two component names "
                       "joined by '__', e.g. 'agent1__cap1'")
    unknown = [p for p in parts if p not in participants]
    if unknown:
      raise ValueError(f"edges.{key}: unknown component(s) {unknown}; valid components are "
                       f"{participants}")
    if parts[0] >= parts[1]:
      raise ValueError(f"edges: invalid edge key {key!r}; names must be distinct and sorted: "
                       f"use {'__'.join(sorted(parts))!r}")
    _check_keys(f"edges.{key}", edge, EDGE_KEYS)
    if edge.get("collide_type", "full") not in COLLIDE_TYPES:
      raise _err(f"edges.{key}.collide_type", f"unknown value {edge['collide_type']!r}; valid "
                 f"values are {list(COLLIDE_TYPES)}")
    if not isinstance(edge.get("reward_fns", {}), Mapping):
      raise _err(f"edges.{key}.reward_fns", "must be a dict of {name: term desc}")
    if not isinstance(edge.get("extra_observers", []), (list, tuple)):
      raise _err(f"edges.{key}.extra_observers", "must be a list of observer dicts")
    if GROUND in parts and (edge.get("extra_observers") or edge.get("reward_fns")):
      raise _err(f"edges.{key}", "ground has no root; only collide_type may be set")

  if "agent_groups" in desc:
    check_agent_groups(desc["agent_groups"])  # names are resolved against the built env

  xml = _render(specs, comps, edges, options, add_ground)
  return Scene(xml=xml, desc=desc, specs=specs, options=options)


def _render(specs, comps, edges, options, add_ground) -> str:
  root = Element("mujoco", {"model": "blx"})
  root.add("compiler", angle="radian", autolimits="true")
  opt = root.add("option", timestep=options["timestep"], gravity=options["gravity"],
                 solver=options["solver"], iterations=options["iterations"],
                 ls_iterations=options["ls_iterations"])
  opt.add("flag", eulerdamp="disable")
  visual = root.add("visual")
  visual.add("headlight", diffuse=(0.6, 0.6, 0.6), ambient=(0.3, 0.3, 0.3), specular=(0, 0, 0))
  asset = root.add("asset")
  asset.add("texture", name="grid", type="2d", builtin="checker", rgb1=(0.1, 0.2, 0.3),
            rgb2=(0.2, 0.3, 0.4), width=300, height=300, mark="edge", markrgb=(0.2, 0.3, 0.4))
  asset.add("material", name="grid", texture="grid", texrepeat=(1, 1), texuniform="true",
            reflectance=0.2)
  world = root.add("worldbody")
  world.add("light", pos=(0, 0, 10), dir=(0, 0, -1), directional="true")
  if add_ground:
    world.add("geom", name=GROUND, type="plane", size=(0, 0, 0.05), material="grid",
              contype=0, conaffinity=0)
  actuators = []
  for name, spec in specs.items():
    comp = comps[name]
    frozen = comp.get("frozen", False)
    bodies = _prefix(spec.bodies, name, frozen)
    if "pos" in comp or "quat" in comp:
      frame = world.add("frame", pos=comp.get("pos"), quat=comp.get("quat"))
      frame.children.extend(bodies)
    else:
      world.children.extend(bodies)
    if not frozen:
      actuators += [(name, joint, gear) for joint, gear in spec.motors]

  contact = Element("contact")
  static = {n for n in specs if comps[n].get("frozen", False)} | {GROUND}
  sides = list(specs) + ([GROUND] if add_ground else [])
  for i, a in enumerate(sides):
    for b in sides[i + 1:]:
      first, second = sorted((a, b))
      collide_type = edges.get(f"{first}__{second}", {}).get("collide_type", "full")
      if collide_type is None or (a in static and b in static):
        continue
      if not all(comps.get(n, {}).get("collide", True) for n in (a, b)):
        continue
      geoms = []
      for n in (first, second):
        if n == GROUND:
          geoms.append([GROUND])
        else:
          own = specs[n].root_colliders if collide_type == "root" else specs[n].colliders
          geoms.append([f"{n}/{g}" for g in own])
      friction = min(1.0 if n == GROUND else specs[n].friction for n in (first, second))
      for g1 in geoms[0]:
        for g2 in geoms[1]:
          contact.add("pair", geom1=g1, geom2=g2, condim=3,
                      friction=(friction, friction, 0.005, 0.0001, 0.0001))
  if contact.children:
    root.children.append(contact)
  if actuators:
    act = root.add("actuator")
    for comp_name, joint, gear in actuators:
      act.add("motor", name=f"{comp_name}/{joint}", joint=f"{comp_name}/{joint}", gear=gear,
              ctrlrange=(-1, 1))
  return root.to_xml() + "\n"


def apply_edits(desc: Mapping[str, Any], edits: Mapping[str, Any] | None) -> dict:
  """Returns a copy of ``desc`` with nested keys set by dotted path.

  ``{"components.cap1.reward_fns.goal.scale": 0.5}`` sets ``desc["components"]["cap1"]
  ["reward_fns"]["goal"]["scale"]``. Every key but the last must already exist.
  """
  desc = copy.deepcopy(dict(desc))
  if edits is None:
    return desc
  if not isinstance(edits, Mapping):
    raise ValueError(f"edits: expected a dict of {{'dotted.path': value}}, got {edits!r}")
  for path, value in edits.items():
    if not isinstance(path, str) or not path:
      raise ValueError(f"edits: keys are dotted paths such as 'components.agent1.pos', got {path!r}")
    keys = path.split(".")
    node: Any = desc
    for depth, key in enumerate(keys[:-1]):
      if not isinstance(node, dict) or key not in node:
        have = sorted(node) if isinstance(node, dict) else type(node).__name__
        raise ValueError(f"edits: {path!r}: no key {key!r} at {'.'.join(keys[:depth]) or 'top level'}"
                         f"; keys there are {have}")
      node = node[key]
    if not isinstance(node, dict):
      raise ValueError(f"edits: {path!r}: {'.'.join(keys[:-1])} is not a dict")
    node[keys[-1]] = copy.deepcopy(value)
  return desc

