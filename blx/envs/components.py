"""Components: the bodies a scene is made of.

A component is a factory ``(**params) -> ComponentSpec``. The spec holds an MJCF fragment (bodies with
unprefixed names, and the motors that drive their joints), the name of its root body and how to read
the root's velocity, the geoms that may take part in contacts, its default observers and its
termination rule. The composer prefixes every name with the component's instance name
(``agent1/torso``) so several copies coexist.

``ant``, ``pro_ant``, ``halfcheetah`` and ``humanoid`` are the paper's Brax v1 bodies
(``blx.envs.brax_bodies``). The light MuJoCo/Gymnasium models (``ant.xml``, ``humanoid.xml``,
``half_cheetah.xml``) stay available as ``gym_ant``, ``gym_humanoid`` and ``gym_halfcheetah``; their
MJCF is generated here.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping

import numpy as np

from blx.envs import brax_bodies  # the paper's bodies
from blx.envs.mjcf import Element
from blx.envs.spec import MAX_LEGS, MIN_LEGS, ComponentSpec, Termination
from blx.options import check_params

__all__ = [
    "ComponentSpec",
    "Termination",
    "register_component",
    "list_components",
    "make_component",
    "MIN_LEGS",
    "MAX_LEGS",
]

# --------------------------------------------------------------------------------------------------
# Ant and procedural ant.

_ANT_JOINT = dict(armature=1, damping=1)
_ANT_GEOM = dict(density=5.0)


def _legged_ant(num_legs: int, angle_offset: float) -> ComponentSpec:
  """An ant-like body: torso sphere (r 0.25) and ``num_legs`` legs at ``angle_offset + 2*pi*i/N``.

  Each leg is the standard ant leg: a fixed 0.2*sqrt(2) hip segment, a thigh of the same length on a
  vertical hip hinge (+-30 deg), and a shin twice as long on a knee hinge (30..70 deg), all capsules of
  radius 0.08; motors of gear 150.
  """
  torso = Element("body", {"name": "torso", "pos": (0, 0, 0.75)})
  torso.add("freejoint", name="root")
  torso.add("geom", name="torso_geom", type="sphere", size=0.25, **_ANT_GEOM)
  motors, feet = [], []
  for i in range(1, num_legs + 1):
    theta = angle_offset + 2 * math.pi * (i - 1) / num_legs
    d = np.array([math.cos(theta), math.sin(theta), 0.0]) * 0.2 * math.sqrt(2)
    leg = torso.add("body", name=f"leg_{i}", pos=(0, 0, 0))
    leg.add("geom", name=f"hip_{i}_geom", type="capsule", fromto=(0, 0, 0, *d), size=0.08,
            **_ANT_GEOM)
    thigh = leg.add("body", name=f"thigh_{i}", pos=tuple(d))
    thigh.add("joint", name=f"hip_{i}", type="hinge", axis=(0, 0, 1),
              range=(-math.radians(30), math.radians(30)), **_ANT_JOINT)
    thigh.add("geom", name=f"thigh_{i}_geom", type="capsule", fromto=(0, 0, 0, *d), size=0.08,
              **_ANT_GEOM)
    shin = thigh.add("body", name=f"shin_{i}", pos=tuple(d))
    knee_axis = (-math.sin(theta), math.cos(theta), 0.0)
    shin.add("joint", name=f"knee_{i}", type="hinge", axis=knee_axis,
             range=(math.radians(30), math.radians(70)), **_ANT_JOINT)
    shin.add("geom", name=f"foot_{i}_geom", type="capsule", fromto=(0, 0, 0, *(2 * d)), size=0.08,
             **_ANT_GEOM)
    motors += [(f"hip_{i}", 150.0), (f"knee_{i}", 150.0)]
    feet.append(f"foot_{i}_geom")
  return brax_bodies.ant_spec(torso, motors, feet, observers=("root_z_joints",),
                              termination=Termination(min_z=0.2, max_z=1.0, check_flip=True))


def gym_ant() -> ComponentSpec:
  """The light MuJoCo/Gymnasium ant (0.91 kg, gear 150, damping 1, armature 1, flip termination):
  four legs at 45, 135, 225 and 315 degrees (8 actuators). Not the paper's body: see ``ant``."""
  return _legged_ant(4, math.pi / 4)


# --------------------------------------------------------------------------------------------------
# Humanoid (Gymnasium humanoid.xml dimensions; actions in [-1, 1] scaled by 0.4 into the gears).

def _capsule(parent: Element, name: str, fromto, size) -> None:
  parent.add("geom", name=name, type="capsule", fromto=fromto, size=size)


def gym_humanoid() -> ComponentSpec:
  """The MuJoCo/Gymnasium humanoid: 17 hinge joints, torso at 1.4 m. Not the paper's body: see
  ``humanoid``."""
  deg = math.radians

  def hinge(body, name, axis, lo, hi, *, armature, damping=5.0, stiffness=10.0, pos=(0, 0, 0)):
    body.add("joint", name=name, type="hinge", axis=axis, pos=pos, range=(deg(lo), deg(hi)),
             armature=armature, damping=damping, stiffness=stiffness)

  torso = Element("body", {"name": "torso", "pos": (0, 0, 1.4)})
  torso.add("freejoint", name="root")
  _capsule(torso, "torso1", (0, -0.07, 0, 0, 0.07, 0), 0.07)
  torso.add("geom", name="head", type="sphere", pos=(0, 0, 0.19), size=0.09)
  _capsule(torso, "uwaist", (-0.01, -0.06, -0.12, -0.01, 0.06, -0.12), 0.06)
  lwaist = torso.add("body", name="lwaist", pos=(-0.01, 0, -0.26), quat=(1, 0, -0.002, 0))
  _capsule(lwaist, "lwaist", (0, -0.06, 0, 0, 0.06, 0), 0.06)
  hinge(lwaist, "abdomen_z", (0, 0, 1), -45, 45, armature=0.02, stiffness=20, pos=(0, 0, 0.065))
  hinge(lwaist, "abdomen_y", (0, 1, 0), -75, 30, armature=0.02, pos=(0, 0, 0.065))
  pelvis = lwaist.add("body", name="pelvis", pos=(0, 0, -0.165), quat=(1, 0, -0.002, 0))
  hinge(pelvis, "abdomen_x", (1, 0, 0), -35, 35, armature=0.02, pos=(0, 0, 0.1))
  _capsule(pelvis, "butt", (-0.02, -0.07, 0, -0.02, 0.07, 0), 0.09)
  for side, sy in (("right", -1.0), ("left", 1.0)):
    thigh = pelvis.add("body", name=f"{side}_thigh", pos=(0, 0.1 * sy, -0.04))
    hinge(thigh, f"{side}_hip_x", (-sy, 0, 0), -25, 5, armature=0.01)
    hinge(thigh, f"{side}_hip_z", (0, 0, -sy), -60, 35, armature=0.01)
    hinge(thigh, f"{side}_hip_y", (0, 1, 0), -110, 20, armature=0.008, stiffness=20)
    _capsule(thigh, f"{side}_thigh1", (0, 0, 0, 0, -0.01 * sy, -0.34), 0.06)
    shin = thigh.add("body", name=f"{side}_shin", pos=(0, -0.01 * sy, -0.403))
    hinge(shin, f"{side}_knee", (0, -1, 0), -160, -2, armature=0.006, damping=1.0, stiffness=1.0,
          pos=(0, 0, 0.02))
    _capsule(shin, f"{side}_shin1", (0, 0, 0, 0, 0, -0.3), 0.049)
    foot = shin.add("body", name=f"{side}_foot", pos=(0, 0, -0.45))
    foot.add("geom", name=f"{side}_foot", type="sphere", pos=(0, 0, 0.1), size=0.075)
  for side, sy in (("right", -1.0), ("left", 1.0)):
    upper = torso.add("body", name=f"{side}_upper_arm", pos=(0, 0.17 * sy, 0.06))
    lo, hi = (-85, 60) if side == "right" else (-60, 85)
    hinge(upper, f"{side}_shoulder1", (2, -sy, 1), lo, hi, armature=0.0068, damping=1.0,
          stiffness=1.0)
    hinge(upper, f"{side}_shoulder2", (0, sy, 1), lo, hi, armature=0.0051, damping=1.0,
          stiffness=1.0)
    upper.add("geom", name=f"{side}_uarm1", type="capsule", fromto=(0, 0, 0, 0.16, 0.16 * sy, -0.16),
              size=(0.04, 0.16))
    lower = upper.add("body", name=f"{side}_lower_arm", pos=(0.18, 0.18 * sy, -0.18))
    hinge(lower, f"{side}_elbow", (0, -1, sy), -90, 50, armature=0.0028, damping=1.0,
          stiffness=0.0)
    _capsule(lower, f"{side}_larm", (0.01, 0.01 * sy, 0.01, 0.17, 0.17 * sy, 0.17), 0.031)
    lower.add("geom", name=f"{side}_hand", type="sphere", pos=(0.18, 0.18 * sy, 0.18), size=0.04)

  gears = dict(abdomen_y=100, abdomen_z=100, abdomen_x=100, right_hip_x=100, right_hip_z=100,
               right_hip_y=300, right_knee=200, left_hip_x=100, left_hip_z=100, left_hip_y=300,
               left_knee=200, right_shoulder1=25, right_shoulder2=25, right_elbow=25,
               left_shoulder1=25, left_shoulder2=25, left_elbow=25)
  return ComponentSpec(
      bodies=(torso,),
      motors=tuple((j, 0.4 * g) for j, g in gears.items()),
      root="torso",
      root_linear={-1: "root"},
      colliders=("torso1", "right_shin1", "left_shin1", "right_foot", "left_foot"),
      root_colliders=("torso1",),
      observers=("root_z_joints",),
      termination=Termination(min_z=1.0, max_z=2.0),
  )


# --------------------------------------------------------------------------------------------------
# Half-cheetah (Gymnasium half_cheetah.xml: the shared skeleton, damped and sprung, 14 kg).

_CHEETAH_JOINTS = dict(  # range, stiffness, damping, gear
    bthigh=((-0.52, 1.05), 240, 6.0, 120),
    bshin=((-0.785, 0.785), 180, 4.5, 90),
    bfoot=((-0.4, 0.785), 120, 3.0, 60),
    fthigh=((-1.0, 0.7), 180, 4.5, 120),
    fshin=((-1.2, 0.87), 120, 3.0, 60),
    ffoot=((-0.5, 0.5), 60, 1.5, 30),
)


def gym_halfcheetah() -> ComponentSpec:
  """The MuJoCo/Gymnasium half-cheetah (14 kg, damped, sprung joints): planar root (x, z slides and
  a y hinge) and 6 joints. Not the paper's body: see ``halfcheetah``."""
  r = brax_bodies.CHEETAH_RADIUS
  half_lengths = [0.5, 0.15] + [link[5] for link in brax_bodies.CHEETAH_LINKS]
  volume = sum(math.pi * r**2 * 2 * h + 4 / 3 * math.pi * r**3 for h in half_lengths)
  density = 14.0 / volume  # Gymnasium sets the total mass to 14 kg
  bodies = brax_bodies.cheetah_skeleton(0.7, density=density, friction=(0.4, 0.1, 0.1))
  for name, (rng, stiffness, damping, _) in _CHEETAH_JOINTS.items():
    bodies[name].add("joint", name=name, type="hinge", axis=(0, 1, 0), range=rng,
                     stiffness=stiffness, damping=damping, armature=0.1, solreflimit=(0.02, 1),
                     solimplimit=(0, 0.8, 0.03))
  return brax_bodies.cheetah_spec(bodies, [(n, float(j[3])) for n, j in _CHEETAH_JOINTS.items()],
                                  ("torso", "head", "bshin", "bfoot", "fshin", "ffoot"))


# --------------------------------------------------------------------------------------------------
# Objects and the point mass.

def singleton(size: float | tuple = 0.25, collider_type: str = "sphere",
              no_obs: bool = False) -> ComponentSpec:
  """A free rigid object: a sphere of radius ``size`` or a capsule ``size=(radius, length)``.

  Mass is radius**3 and the inertia 1 I_3 about every axis, as Braxlines' singleton sets them (not
  the solid sphere's 0.4 m r^2: Braxlines' 0.5 m ball of Ant Push is 0.125 kg with 80 times that
  sphere's inertia, so it turns slowly and slides). It starts resting on the floor (1 mm above it)
  under its component position.
  """
  if collider_type not in ("sphere", "capsule"):
    raise ValueError(
        f"singleton: collider_type={collider_type!r} is not valid; valid values are "
        "'sphere', 'capsule'")
  if collider_type == "sphere":
    if not isinstance(size, (int, float)) or size <= 0:
      raise ValueError(f"singleton: sphere size must be a positive number, got {size!r}")
    radius, geom = float(size), dict(type="sphere", size=float(size))
  else:
    if (not isinstance(size, (tuple, list)) or len(size) != 2
        or not all(isinstance(s, (int, float)) and s > 0 for s in size)):
      raise ValueError(f"singleton: capsule size must be (radius, length), got {size!r}")
    radius = float(size[0])
    geom = dict(type="capsule", size=(radius, float(size[1]) / 2), quat=(0.7071068, 0, 0.7071068, 0))
  body = Element("body", {"name": "object", "pos": (0, 0, radius)})
  body.add("freejoint", name="root")
  body.add("inertial", pos=(0, 0, 0), mass=radius**3, diaginertia=(1.0, 1.0, 1.0))
  body.add("geom", name="object_geom", mass=0, **geom)
  return ComponentSpec(
      bodies=(body,),
      motors=(),
      root="object",
      root_linear={-1: "root"},
      colliders=("object_geom",),
      root_colliders=("object_geom",),
      observers=() if no_obs else ("qp",),
      rest_on_ground=True,
  )


def point(gear: float = 4.0, damping: float = 2.0) -> ComponentSpec:
  """A point mass (1 kg) moving in the plane on two slide joints, driven by two motors.

  Viscous damping bounds its speed at ``gear / damping`` m/s. It has no colliders: it moves freely
  and costs almost nothing to simulate, the cheap default for CPU runs.
  """
  if not gear > 0 or not damping >= 0:
    raise ValueError(f"point: gear must be > 0 and damping >= 0 (damping < 0 feeds energy in), got "
                     f"gear={gear!r}, damping={damping!r}")
  body = Element("body", {"name": "root", "pos": (0, 0, 0.1)})
  for name, axis in (("x", (1, 0, 0)), ("y", (0, 1, 0))):
    body.add("joint", name=name, type="slide", axis=axis, damping=damping, limited=False)
  body.add("geom", name="point_geom", type="sphere", size=0.1, mass=1.0)
  return ComponentSpec(
      bodies=(body,),
      motors=(("x", float(gear)), ("y", float(gear))),
      root="root",
      root_linear={0: "x", 1: "y"},
      observers=(dict(observer_type="root", sdcomp="pos", indices=(0, 1)),
                 dict(observer_type="root", sdcomp="vel", indices=(0, 1))),
  )


# --------------------------------------------------------------------------------------------------
# Registry.

_COMPONENTS: dict[str, Callable[..., ComponentSpec]] = {
    "ant": brax_bodies.ant,
    "pro_ant": brax_bodies.pro_ant,
    "octopus": brax_bodies.octopus,
    "humanoid": brax_bodies.humanoid,
    "halfcheetah": brax_bodies.halfcheetah,
    "gym_ant": gym_ant,
    "gym_humanoid": gym_humanoid,
    "gym_halfcheetah": gym_halfcheetah,
    "singleton": singleton,
    "point": point,
}
GROUND = "ground"


def register_component(name: str, factory: Callable[..., ComponentSpec]) -> None:
  """Registers ``factory(**params) -> ComponentSpec`` under ``name`` (fails if taken)."""
  if not isinstance(name, str) or not name or name == GROUND:
    raise ValueError(f"component name must be a non-empty string other than {GROUND!r}, got {name!r}")
  if name in _COMPONENTS:
    raise ValueError(f"component {name!r} is already registered")
  if not callable(factory):
    raise ValueError(f"component factory for {name!r} must be callable, got {factory!r}")
  _COMPONENTS[name] = factory


def list_components() -> list[str]:
  """Names of the registered components (``ground`` is added to scenes automatically)."""
  return sorted(_COMPONENTS) + [GROUND]


def make_component(name: str, params: Mapping[str, Any] | None = None,
                   where: str = "component") -> ComponentSpec:
  """Builds the spec of registered component ``name`` with ``params``, checking them first."""
  if name not in _COMPONENTS:
    raise ValueError(f"{where}: unknown component {name!r}; valid components are "
                     f"{sorted(_COMPONENTS)}")
  factory = _COMPONENTS[name]
  params = dict(params or {})
  check_params(f"{where} ({name})", factory, params)
  spec = factory(**params)
  if not isinstance(spec, ComponentSpec):
    raise ValueError(f"{where}: factory of component {name!r} returned {type(spec).__name__}, "
                     "not ComponentSpec")
  return spec
