"""The paper's bodies: Brax v1's ant, procedural ant, half-cheetah and humanoid, rebuilt in MJCF.

The Braxlines paper trained on Brax v1 (tag v0.0.6), not on the MuJoCo/Gym models. Those bodies are
heavier, more damped and collide on fewer geoms, and that is what the paper's skills and tables were
learned on. The numbers here are Brax v0.0.6's (``shared/reference/brax-v1-bodies.md`` lists each with
its meaning); the MJCF is written for this library.

What carries over exactly: masses, isotropic inertias (``<inertial>``; a Brax body's position is its
centre of mass), link lengths, joint axes and ranges, motor strengths (MJCF ``gear``), joint angular
damping (MJCF ``damping``), the collide lists (only those geoms get contact pairs), friction, gravity,
the control step (0.05 s for ant and cheetah, 0.015 s for the humanoid), the default pose (range
midpoints unless Brax sets an angle, lifted so the lowest collider touches the floor), the motor
torque cut while a joint is past its range, and the termination heights.

What MJX cannot copy, and what blx does instead:

* **Soft joints.** Brax v1 joints are springs (stiffness 5000-15000) that let the anchors stretch and
  the hinge axes tilt. MJCF joints are rigid. The rigid ant rests about 2 cm higher (0.362 m against
  Brax's 0.342 m) and has no fast 3 cm drop in its first 0.15 s.
* **Soft joint limits.** Brax pushes back with ``limit_strength`` N m/rad, lightly damped (the ant's
  damping ratio is about 0.35). blx uses MuJoCo's limit constraint with the same natural frequency
  (``solreflimit`` time constant 10 ms; MuJoCo raises it to two timesteps where needed) but
  critically damped by default: at a ratio of 0.35 and the 10 ms substep the MJX physics blew up
  under bang-bang torques (11 of 48 C MuJoCo episodes of random +-1 actions, and NaN observations
  within 3-30 M steps of GAIL, DIAYN and AIRL training on the GPU). At Brax's 5 ms substep the
  ratio 0.35 is stable (no blow-up in 48 C MuJoCo and 512 MJX float32 episodes of 1000 such steps)
  and is the ant's ``limit_damping=0.35`` parameter: a hip driven into its limit then bounces back
  as Brax's does, but the ant runs no faster (open-loop gait search, elite means 1.84 and 2.41 m/s
  against 1.96 and 2.06 critically damped), so the default stays 1.0. Do not combine 0.35 with
  :data:`ANT_FAST_OPTIONS`.
* **Impulse contacts.** Brax resolves contacts with velocity impulses, Baumgarte push-out and no
  friction below 1 cm/s of sliding; MJX uses MuJoCo's soft constraints (pyramidal cone, condim 3).
* **The contact observation.** Brax reports each body's contact velocity change Δv and Δω summed over
  the substeps (``info.contact``). blx reports the same quantity computed from MJX's contact forces:
  Δv_b = Σ_substeps F_b h / m_b and Δω_b = Σ_substeps τ_b h / I_b (torque about the body's centre of
  mass), clipped to ±1 for the ant as in Brax. Brax's impulses act on one body at a time, MuJoCo's
  forces on the whole articulated body, so magnitudes differ; the signs and which body touches do not.
  The forces are those MuJoCo's solver reports; with the one Newton iteration blx runs, they can
  differ from the momentum the contacts actually transferred in a violent step.
  Brax's 87-dim ant observation also has 6 always-zero entries for the frozen ground; blx omits them
  (81 dims), so every index the paper uses (13, 14) is where the paper has it.
* **The v0.0.6 rotation bug** (orientations integrated at twice the angular velocity) is not copied.
* **Integration.** One env step is ``substeps`` MuJoCo steps of semi-implicit Euler. The ant's envs
  use Brax's own substep, 10 steps of 5 ms per 0.05 s control step (:data:`ANT_OPTIONS`).
  :data:`ANT_FAST_OPTIONS` (5 steps of 10 ms) halves the physics and is a deviation: both agree on
  the fact sheet's random-action signatures, but not on how fast the ant can run. Under the same
  open-loop gait search (cross-entropy over sinusoid gaits; C MuJoCo, and Brax's ``legacy_spring``
  physics on this config) the searches' elite gaits run 2.6-3.3 m/s on Brax, 2.0-2.1 m/s at 5 ms and
  1.5-1.6 m/s at 10 ms; gaits found at 5 ms average 1.8-1.9 m/s, and 0.9-1.2 m/s replayed at 10 ms.
  Task PPO on ``ant_run`` (target (4, 0) m/s) ends 0.94 m/s from the target at 5 ms and 1.49 m/s at
  10 ms (``benchmarks/RESULTS.md``, session 5).
* **Joint velocity sign.** Brax observes (ω_parent - ω_child)·axis, minus the angle's rate; blx
  observes the angle's rate (MuJoCo's ``qvel``).
"""

from __future__ import annotations

import math

import numpy as np

from blx.envs.spec import MAX_LEGS, MIN_LEGS, ComponentSpec, Termination
from blx.envs.mjcf import Element

__all__ = ["ant", "pro_ant", "octopus", "halfcheetah", "humanoid", "ANT_DAMPING", "ANT_STRENGTH",
           "ANT_OPTIONS", "ANT_FAST_OPTIONS",
           "CHEETAH_LINKS", "CHEETAH_RADIUS", "cheetah_skeleton", "cheetah_spec", "ant_spec"]

ANT_DAMPING = 35.0        # Brax joint angular_damping, N m s/rad
ANT_STRENGTH = 300.0      # Brax motor strength (v0.0.6 stock ant)
# Braxlines' procedural ant at the paper's commit (2821f78, 2021-10-04); 350 from 2021-10-12.
PRO_ANT_STRENGTH = 300.0
# Its leg (components/pro_ant.py): a thigh capsule (r 0.08, 0.44284 m end to end) centred on its
# hip, the hip 0.30142 m out from the torso's centre; the knee 0.14142 m past the hip; the shin's
# centre of mass 0.28284 m past the knee and its foot sphere (the shin capsule's outer end) 0.28284
# m further.
PRO_ANT_THIGH_LENGTH, PRO_ANT_SHIN_LENGTH = 0.4428427219390869, 0.7256854176521301
PRO_ANT_RADIUS = 0.08
PRO_ANT_HIP = PRO_ANT_THIGH_LENGTH / 2 + PRO_ANT_RADIUS
PRO_ANT_KNEE = PRO_ANT_THIGH_LENGTH / 2 - PRO_ANT_RADIUS
PRO_ANT_SHIN = PRO_ANT_SHIN_LENGTH / 2 - PRO_ANT_RADIUS
ANT_LIMIT = (0.01, 1.0)   # solreflimit: 100 rad/s (Brax's limit_strength 5000 on inertia-1 links), damped
_UNIT = dict(diaginertia=(1.0, 1.0, 1.0))
# Brax's ant steps 0.05 s as 10 substeps of 5 ms; the registered ant envs do the same. The Newton
# solve keeps MJX's one iteration: the ant's paper rows meet the paper with it, except GCRL.
# GCRL's MI was higher with ``iterations=4`` on both seeds tried (benchmarks/RESULTS.md, session 11),
# at about 2.6x the cost per env step, so four iterations are an env edit, not the default.
ANT_OPTIONS = dict(timestep=0.005, substeps=10)
# Half the physics per control step; slows the ant's fastest gaits (see the module docstring).
ANT_FAST_OPTIONS = dict(timestep=0.01, substeps=5)


def _inertial(body: Element, mass: float, inertia: float | None = None, pos=(0, 0, 0)) -> None:
  diag = _UNIT["diaginertia"] if inertia is None else (inertia,) * 3
  body.add("inertial", pos=pos, mass=mass, diaginertia=diag)


def ant_spec(torso: Element, motors, feet, **extra) -> ComponentSpec:
  """The ComponentSpec of an ant (Brax's or Gym's): a free torso whose sphere and the feet collide."""
  return ComponentSpec(bodies=(torso,), motors=tuple(motors), root="torso",
                       root_linear={-1: "root"}, colliders=("torso_geom", *feet),
                       root_colliders=("torso_geom",), **extra)


def _check_limit_damping(where: str, value) -> float:
  if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
      math.isfinite(value) and value > 0):
    raise ValueError(f"{where}: limit_damping={value!r} must be a finite number > 0 (a damping ratio: "
                     "0.35 is Brax's, 1.0 critically damped)")
  return float(value)


def _brax_torso() -> Element:
  """A Brax v1 ant's torso: a free 10 kg sphere (r 0.25, inertia 1 I_3), 0.5 m up."""
  torso = Element("body", {"name": "torso", "pos": (0, 0, 0.5)})
  torso.add("freejoint", name="root")
  _inertial(torso, 10.0)
  torso.add("geom", name="torso_geom", type="sphere", size=0.25, mass=0)
  return torso


def _brax_limits(where: str, limit_damping) -> dict:
  """The joint attributes every Brax ant leg shares: limited, damped with 35 N m s/rad."""
  damping_ratio = _check_limit_damping(where, limit_damping)
  return dict(limited="true", solreflimit=(ANT_LIMIT[0], damping_ratio), damping=ANT_DAMPING,
              armature=0)


def _brax_ant_spec(torso: Element, motors, leg_colliders, default: dict, bodies, *,
                   check_flip: bool) -> ComponentSpec:
  """The ComponentSpec of a Brax ant (stock or procedural): Brax's observation with the contact
  change of every body, the height rule (and the upright rule where ``check_flip``), the torque
  cut, and the rest pose on the floor."""
  return ant_spec(torso, motors, leg_colliders, observers=("root_z_joints", "cfrc"),
                  termination=Termination(min_z=0.2, max_z=1.0, check_flip=check_flip),
                  default_qpos=default, rest_on_ground=True, torque_cut=True,
                  contact_bodies=tuple(bodies), contact_clip=1.0)


def ant(limit_damping: float = ANT_LIMIT[1]) -> ComponentSpec:
  """Brax v1's stock ant (the paper's): 18 kg, strength 300, damping 35, legs at 45 + 90 k deg.

  Leg ``i`` points along ``theta_i = pi / 4 + pi (i - 1) / 2``. Its hip sits 0.2 sqrt(2) m out from
  the torso centre on a vertical hinge (+-30 deg); its thigh (COM at the segment's middle) ends at
  the ankle, a hinge across the leg (30..70 deg, positive = foot down; legs 2 and 3 have the axis
  flipped and the range negated, so their angles read with the opposite sign); the shin's COM is
  0.2 sqrt(2) m past the ankle and its foot sphere (r 0.08, the only collider of the leg) 0.4
  sqrt(2) m past it. Every inertia is 1 I_3.

  Observation (81): torso z, quaternion, 8 joint angles, torso velocity (world), angular velocity
  (world), 8 joint velocities, then contact Δv (9 bodies x 3) and Δω (9 x 3), clipped to +-1. Episodes
  end when the torso leaves z in [0.2, 1.0]; there is no upside-down rule (Brax v0.0.6). Brax's
  control step is ``global_options=ANT_OPTIONS`` (the registered ant envs set it).

  ``limit_damping``: the damping ratio of the joint limits (see the module docstring).
  """
  limits = _brax_limits("ant", limit_damping)
  seg = 0.2 * math.sqrt(2)
  torso = _brax_torso()
  motors, feet, default, bodies = [], [], {}, ["torso"]
  for i in range(1, 5):
    theta = math.pi / 4 + 2 * math.pi * (i - 1) / 4
    u = np.array([math.cos(theta), math.sin(theta), 0.0])
    thigh = torso.add("body", name=f"thigh_{i}", pos=tuple(seg * u))
    thigh.add("joint", name=f"hip_{i}", type="hinge", axis=(0, 0, 1),
              range=(-math.radians(30), math.radians(30)), **limits)
    _inertial(thigh, 1.0, pos=tuple(0.5 * seg * u))
    thigh.add("geom", name=f"thigh_{i}_geom", type="capsule", fromto=(0, 0, 0, *(seg * u)),
              size=0.08, mass=0)
    shin = thigh.add("body", name=f"shin_{i}", pos=tuple(seg * u))
    axis = np.array([-math.sin(theta), math.cos(theta), 0.0])
    lo, hi = 30.0, 70.0
    if i in (2, 3):  # the stock ant flips these two axes and negates their ranges
      axis, lo, hi = -axis, -70.0, -30.0
    shin.add("joint", name=f"ankle_{i}", type="hinge", axis=tuple(np.round(axis, 12)),
             range=(math.radians(lo), math.radians(hi)), **limits)
    _inertial(shin, 1.0, pos=tuple(seg * u))
    shin.add("geom", name=f"shin_{i}_geom", type="capsule", fromto=(0, 0, 0, *(2 * seg * u)),
             size=0.08, mass=0)
    shin.add("geom", name=f"foot_{i}_geom", type="sphere", pos=tuple(2 * seg * u), size=0.08,
             mass=0)
    motors += [(f"hip_{i}", ANT_STRENGTH), (f"ankle_{i}", ANT_STRENGTH)]
    feet.append(f"foot_{i}_geom")
    default[f"ankle_{i}"] = math.radians(0.5 * (lo + hi))
    bodies += [f"thigh_{i}", f"shin_{i}"]
  return _brax_ant_spec(torso, motors, feet, default, bodies, check_flip=False)


def pro_ant(num_legs: int = 4, limit_damping: float = ANT_LIMIT[1],
            strength: float = PRO_ANT_STRENGTH) -> ComponentSpec:
  """Braxlines' procedural ant as the paper ran it (``components/pro_ant.py`` at 2821f78):
  ``num_legs`` (2..16) legs from +x, each a hip on a vertical hinge (+-30 deg) and a knee across
  the leg (30..70 deg, positive = foot down), on a 10 kg torso sphere (r 0.25).

  The leg is not the stock ant's (:func:`ant`): the hip sits 0.301 m out with the thigh's centre of
  mass on it, the knee 0.141 m past the hip, the shin's centre of mass 0.283 m past the knee and the
  foot 0.566 m past it (1.009 m from the torso's centre, against the stock ant's 1.131 m). The
  colliders are the torso, both thigh capsules' end spheres (MuJoCo: the whole thigh capsule) and
  the feet. Every link is 1 kg with inertia 1, every joint damped with 35 N m s/rad. The episode
  ends when the torso leaves z in [0.2, 1.0] or turns upside down (the original's upright rule,
  which its ant component has not).

  ``strength``: the motors' (300, the paper's; Braxlines raised it to 350 a week after).
  ``limit_damping``: the damping ratio of the joint limits, as for :func:`ant`.
  """
  if not isinstance(num_legs, int) or isinstance(num_legs, bool) or not (
      MIN_LEGS <= num_legs <= MAX_LEGS):
    raise ValueError(
        f"pro_ant: num_legs={num_legs!r} is out of range; valid values are {MIN_LEGS}..{MAX_LEGS}")
  if isinstance(strength, bool) or not isinstance(strength, (int, float)) or not (
      math.isfinite(strength) and strength > 0):
    raise ValueError(f"pro_ant: strength={strength!r} must be a finite number > 0 (N m per unit "
                     f"action; the paper's is {PRO_ANT_STRENGTH:g})")
  limits = _brax_limits("pro_ant", limit_damping)
  torso = _brax_torso()
  motors, colliders, default, bodies = [], [], {}, ["torso"]
  for i in range(1, num_legs + 1):
    theta = 2 * math.pi * (i - 1) / num_legs
    u = np.array([math.cos(theta), math.sin(theta), 0.0])
    at = lambda r: tuple(np.round(r * u, 12))
    thigh = torso.add("body", name=f"thigh_{i}", pos=at(PRO_ANT_HIP))
    thigh.add("joint", name=f"hip_{i}", type="hinge", axis=(0, 0, 1),
              range=(-math.radians(30), math.radians(30)), **limits)
    _inertial(thigh, 1.0)
    thigh.add("geom", name=f"thigh_{i}_geom", type="capsule", size=0.08, mass=0,
              fromto=(*at(-PRO_ANT_KNEE), *at(PRO_ANT_KNEE)))
    shin = thigh.add("body", name=f"shin_{i}", pos=at(PRO_ANT_KNEE))
    shin.add("joint", name=f"ankle_{i}", type="hinge",
             axis=tuple(np.round((-math.sin(theta), math.cos(theta), 0.0), 12)),
             range=(math.radians(30), math.radians(70)), **limits)
    _inertial(shin, 1.0, pos=at(PRO_ANT_SHIN))
    shin.add("geom", name=f"shin_{i}_geom", type="capsule", fromto=(0, 0, 0, *at(2 * PRO_ANT_SHIN)),
             size=0.08, mass=0)
    shin.add("geom", name=f"foot_{i}_geom", type="sphere", pos=at(2 * PRO_ANT_SHIN), size=0.08,
             mass=0)
    motors += [(f"hip_{i}", float(strength)), (f"ankle_{i}", float(strength))]
    colliders += [f"thigh_{i}_geom", f"foot_{i}_geom"]
    default[f"ankle_{i}"] = math.radians(50.0)
    bodies += [f"thigh_{i}", f"shin_{i}"]
  return _brax_ant_spec(torso, motors, colliders, default, bodies, check_flip=True)


# Braxlines' octopus (its ``components/octopus.py``): every body 1 kg with inertia 1, every joint a
# hinge of +-45 deg, angular damping 10, limit strength 400, motor strength 150.
OCTOPUS_STRENGTH = 150.0
OCTOPUS_DAMPING = 10.0
# solreflimit time constant: the ant's 10 ms scaled by sqrt(5000 / 400) for Brax's limit strengths
# (the ant's 5000 against the octopus's 400 N m/rad), critically damped as the ant's.
OCTOPUS_LIMIT = (0.01 * math.sqrt(5000.0 / 400.0), 1.0)
OCTOPUS_ARMS = 8


def _capsule_along(body: Element, name: str, centre, direction, length: float, radius: float):
  """A capsule of Brax's ``length`` (end to end, caps included) centred at ``centre``."""
  half = 0.5 * length - radius
  c, d = np.asarray(centre, float), np.asarray(direction, float)
  body.add("geom", name=name, type="capsule", size=radius, mass=0,
           fromto=tuple(np.round(np.concatenate([c - half * d, c + half * d]), 12)))


def octopus(all_collide: bool = False) -> ComponentSpec:
  """Braxlines' octopus: a free root, a yawing body, a head and 8 arms of 3 links; 27 bodies of 1 kg
  (inertia 1), 26 hinges of +-45 deg, each driven by a motor of strength 150.

  The root (a 1 cm sphere) carries the body on a vertical hinge; the head (a capsule of radius
  6.2 cm and length 23.4 cm, leaning 45 deg back) hangs on the body from a hinge about x. Arm
  ``i`` leaves the head 1.5 cm above the root, turned 45 i deg about z, and lies flat: a 5.8 cm link
  then two of 11.8 cm (radius 2.2 cm), 7.4 cm apart, each on a hinge across the arm (about the
  link's own x).
  As in Brax v1, a body's centre of mass is its joint point. The episode ends when the root turns
  upside down (Braxlines' upright rule); there is no height rule.

  ``all_collide``: the original's collide list was rebuilt inside its loop over the arms, so only
  the three links of the last arm (arm 7) collide with the floor and everything else passes through
  it. That is the default, as the original's code ran it. ``True`` gives what the loop meant: the
  root, body, head and every arm link collide (a deviation).

  What differs from Brax v1 beyond the notes above: the arm capsules lie exactly along the link
  (Brax tilts them by 0.05 deg), and the joints are rigid hinges (Brax's are springs of stiffness
  7500).
  """
  if not isinstance(all_collide, bool):
    raise ValueError(f"octopus: all_collide={all_collide!r} must be True or False")
  limits = dict(limited="true", range=(-math.radians(45), math.radians(45)),
                solreflimit=OCTOPUS_LIMIT, damping=OCTOPUS_DAMPING, armature=0)
  root = Element("body", {"name": "root", "pos": (0, 0, 0)})
  root.add("freejoint", name="root")
  _inertial(root, 1.0)
  root.add("geom", name="root_geom", type="sphere", pos=(0, 0, 0.01), size=0.01, mass=0)
  body = root.add("body", name="body", pos=(0, 0, 0))
  body.add("joint", name="body_yaw", type="hinge", axis=(0, 0, 1), **limits)
  _inertial(body, 1.0)
  body.add("geom", name="body_geom", type="sphere", pos=(0, 0, 0.01), size=0.01, mass=0)
  head = body.add("body", name="head", pos=(0, 0, 0))
  head.add("joint", name="head_pitch", type="hinge", axis=(1, 0, 0), **limits)
  _inertial(head, 1.0)
  lean = math.radians(45)
  _capsule_along(head, "head_geom", (-0.037, 0, 0.1181), (-math.sin(lean), 0, math.cos(lean)),
                 0.234, 0.062)
  motors = [("body_yaw", OCTOPUS_STRENGTH), ("head_pitch", OCTOPUS_STRENGTH)]
  colliders, bodies = ["root_geom", "body_geom", "head_geom"], ["root", "body", "head"]
  arm_links = []
  for i in range(OCTOPUS_ARMS):
    yaw = math.radians(45.0 * i)
    parent, pos = head, (0, 0, 0.015)
    for k, (centre, length) in enumerate(((0.0683, 0.058), (0.037, 0.118), (0.037, 0.118))):
      name = f"arm_{i}_{k}"
      attrs = dict(name=name, pos=pos)
      if k == 0:
        attrs["quat"] = (math.cos(yaw / 2), 0, 0, math.sin(yaw / 2))
      link = parent.add("body", **attrs)
      link.add("joint", name=name, type="hinge", axis=(1, 0, 0), **limits)
      _inertial(link, 1.0)
      _capsule_along(link, f"{name}_geom", (0, centre, 0), (0, 1, 0), length, 0.022)
      motors.append((name, OCTOPUS_STRENGTH))
      arm_links.append(f"{name}_geom")
      bodies.append(name)
      parent, pos = link, (0, 0.074, 0)
  colliders = colliders + arm_links if all_collide else arm_links[-3:]
  return ComponentSpec(
      bodies=(root,), motors=tuple(motors), root="root", root_linear={-1: "root"},
      colliders=tuple(colliders),
      root_colliders=("root_geom",) if all_collide else (),
      observers=("root_z_joints",),
      termination=Termination(check_flip=True),
      rest_on_ground=True,
      torque_cut=True,
  )


# --------------------------------------------------------------------------------------------------
# Half-cheetah. The link geometry is MuJoCo's half_cheetah.xml, which Brax v1 copied; ``gym_halfcheetah``
# builds on the same skeleton.

CHEETAH_RADIUS = 0.046
# name, parent, joint position in the parent, capsule position, capsule angle about y (rad),
# capsule half-length.
CHEETAH_LINKS = (
    ("bthigh", "torso", (-0.5, 0, 0), (0.1, 0, -0.13), -3.8, 0.145),
    ("bshin", "bthigh", (0.16, 0, -0.25), (-0.14, 0, -0.07), -2.03, 0.15),
    ("bfoot", "bshin", (-0.28, 0, -0.14), (0.03, 0, -0.097), -0.27, 0.094),
    ("fthigh", "torso", (0.5, 0, 0), (-0.07, 0, -0.12), 0.52, 0.133),
    ("fshin", "fthigh", (-0.14, 0, -0.24), (0.065, 0, -0.09), -0.6, 0.106),
    ("ffoot", "fshin", (0.13, 0, -0.18), (0.045, 0, -0.07), -0.6, 0.07),
)


def cheetah_skeleton(torso_z: float, **geom_kw) -> dict[str, Element]:
  """The half-cheetah's bodies and capsules, ``{name: body}`` from ``"torso"`` down: a planar root
  (x, z slides and a y hinge, unlimited and undamped) and the six links, without their hinges or
  inertia, which each body adds. ``geom_kw`` goes to every capsule (mass, density, friction)."""
  torso = Element("body", {"name": "torso", "pos": (0, 0, torso_z)})
  for name, axis, kind in (("rootx", (1, 0, 0), "slide"), ("rootz", (0, 0, 1), "slide"),
                           ("rooty", (0, 1, 0), "hinge")):
    torso.add("joint", name=name, type=kind, axis=axis, armature=0, damping=0, stiffness=0,
              limited="false")
  torso.add("geom", name="torso", type="capsule", fromto=(-0.5, 0, 0, 0.5, 0, 0),
            size=CHEETAH_RADIUS, **geom_kw)
  torso.add("geom", name="head", type="capsule", pos=(0.6, 0, 0.1), axisangle=(0, 1, 0, 0.87),
            size=(CHEETAH_RADIUS, 0.15), **geom_kw)
  bodies = {"torso": torso}
  for name, parent, pos, gpos, angle, half in CHEETAH_LINKS:
    bodies[name] = bodies[parent].add("body", name=name, pos=pos)
    bodies[name].add("geom", name=name, type="capsule", pos=gpos, axisangle=(0, 1, 0, angle),
                     size=(CHEETAH_RADIUS, half), **geom_kw)
  return bodies


def cheetah_spec(bodies: dict[str, Element], motors, colliders, **extra) -> ComponentSpec:
  """The ComponentSpec of a half-cheetah built on ``cheetah_skeleton``: planar, no termination."""
  return ComponentSpec(
      bodies=(bodies["torso"],), motors=tuple(motors), root="torso",
      root_linear={0: "rootx", 2: "rootz"}, root_angular={1: "rooty"}, colliders=tuple(colliders),
      root_colliders=("torso", "head"), observers=("root_z_joints",), termination=None,
      planar_axes=(0,), friction=0.4, **extra)


# Brax v1: MuJoCo's geometry at density 1000 without settotalmass (21.18 kg), every link's COM at
# its joint, isotropic inertias, no joint damping, springs or armature.
_CHEETAH = dict(  # range (deg), mass, inertia, strength
    bthigh=((-29.79, 60.16), 2.3355, 0.029636, 120.0),
    bshin=((-44.98, 44.98), 2.4020, 0.032029, 90.0),
    bfoot=((-22.92, 44.98), 1.6575, 0.011706, 60.0),
    fthigh=((-57.30, 40.11), 2.1760, 0.024391, 120.0),
    fshin=((-68.75, 49.85), 1.8170, 0.014955, 60.0),
    ffoot=((-28.65, 28.65), 1.3384, 0.0067111, 30.0),
)
# Four Newton iterations, not the one the other bodies use: light links (down to 1.3 kg, inertia
# 0.0067) on a 9.5 kg torso make the constraint problem badly conditioned, and one iteration leaves
# float32 MJX and float64 MuJoCo 0.9 m apart after three random steps; four agree to 4e-5.
CHEETAH_OPTIONS = dict(timestep=0.003125, substeps=16, iterations=4)


def halfcheetah() -> ComponentSpec:
  """Brax v1's half-cheetah: planar (x, z slides, y hinge), 21.18 kg, no joint damping.

  Colliders: torso and head, thighs and feet (not the shins), friction 0.4. No termination. The
  default pose puts every joint at its range midpoint. Observation (23): torso z, quaternion, 6
  angles, torso velocity (y = 0), angular velocity, 6 joint velocities; vx is index 11.
  """
  bodies = cheetah_skeleton(0.6, mass=0)
  _inertial(bodies["torso"], 9.4573, 0.94480)
  default = {}
  for name, ((lo, hi), mass, inertia, _) in _CHEETAH.items():
    bodies[name].add("joint", name=name, type="hinge", axis=(0, 1, 0),
                     range=(math.radians(lo), math.radians(hi)), damping=0, stiffness=0,
                     armature=0, limited="true", solreflimit=ANT_LIMIT)
    _inertial(bodies[name], mass, inertia)
    default[name] = math.radians(0.5 * (lo + hi))
  return cheetah_spec(bodies, [(n, row[3]) for n, row in _CHEETAH.items()],
                      ("torso", "head", "bthigh", "bfoot", "fthigh", "ffoot"),
                      default_qpos=default, rest_on_ground=True, torque_cut=True)


# --------------------------------------------------------------------------------------------------
# Humanoid: MuJoCo's link geometry with Brax's masses, unit inertias (COM at the joint side, as Brax
# body positions), strength 300 (legs, abdomen) / 75 (arms), angular damping 20, Brax's narrower hip
# ranges, and contacts on the shins and feet only.

HUMANOID_OPTIONS = dict(timestep=0.003, substeps=5)


def humanoid() -> ComponentSpec:
  """Brax v1's humanoid: 42.1 kg, 17 motors, every inertia 1 I_3, only shins and feet collide.

  Episodes end when the torso leaves z in [0.65, 2.1]. The default pose has the knees at -25 deg and
  every other joint at its range midpoint. Observation: torso z, quaternion, 17 joint angles, torso
  velocity and angular velocity (world), 17 joint velocities (45); xy velocity at (22, 23) as in the
  paper. Brax's further 165 entries, functions of the state (per-body inertia and velocities about
  the centre of mass), are the observer ``"com"`` (an option). Brax's 2- and 3-axis joints are
  chains of hinges here, with Brax's ranges read in MuJoCo's sense: that reading reproduces Brax's
  default pose exactly (torso z 1.2439, centre of mass (0.063, 0, 0.8836)). Brax's reset adds one
  control step of random actions U[0, 0.5); blx's reset is the deterministic default pose unless
  ``global_options.reset_actions`` is 0.5, which takes that step (the torso then drops from 1.2449
  to 1.2438 m, Brax's from 1.2439 to 1.2430). It is off by default, so that the rows trained so far
  stay reproducible from their configs.

  Of the entries of Brax's observation that are not functions of the state, two are observers:
  ``"cfrc"``, the shins' contact Δv and Δω over the last step (unclipped, as Brax's; only the
  shins touch the floor, so Brax's other bodies' entries are 0), and ``"actuator"``, what each
  motor applied over the last step. The component observes the 45 alone by default, as Braxlines'
  composer humanoid; the registered env ``humanoid``, the paper's stock env, adds both
  (``blx.envs.descs.HUMANOID_OBSERVERS``: obs 74, xy velocity still at 22-23).
  """
  deg = math.radians
  limits = dict(limited="true", damping=20.0, armature=0, solreflimit=ANT_LIMIT)
  default: dict[str, float] = {}

  def hinge(body, name, axis, lo, hi, pos=(0, 0, 0)):
    body.add("joint", name=name, type="hinge", axis=axis, pos=pos, range=(deg(lo), deg(hi)),
             **limits)
    default[name] = deg(0.5 * (lo + hi))

  torso = Element("body", {"name": "torso", "pos": (0, 0, 1.4)})
  torso.add("freejoint", name="root")
  _inertial(torso, 8.9075)
  torso.add("geom", name="torso1", type="capsule", fromto=(0, -0.07, 0, 0, 0.07, 0), size=0.07,
            mass=0)
  torso.add("geom", name="head", type="sphere", pos=(0, 0, 0.19), size=0.09, mass=0)
  torso.add("geom", name="uwaist", type="capsule", fromto=(-0.01, -0.06, -0.12, -0.01, 0.06, -0.12),
            size=0.06, mass=0)
  lwaist = torso.add("body", name="lwaist", pos=(-0.01, 0, -0.26))
  _inertial(lwaist, 2.2619)
  lwaist.add("geom", name="lwaist", type="capsule", fromto=(0, -0.06, 0, 0, 0.06, 0), size=0.06,
             mass=0)
  hinge(lwaist, "abdomen_z", (0, 0, 1), -45, 45, pos=(0, 0, 0.065))
  hinge(lwaist, "abdomen_y", (0, 1, 0), -75, 30, pos=(0, 0, 0.065))
  pelvis = lwaist.add("body", name="pelvis", pos=(0, 0, -0.165))
  _inertial(pelvis, 6.6162)
  hinge(pelvis, "abdomen_x", (1, 0, 0), -35, 35, pos=(0, 0, 0.1))
  pelvis.add("geom", name="butt", type="capsule", fromto=(-0.02, -0.07, 0, -0.02, 0.07, 0),
             size=0.09, mass=0)
  colliders = []
  for side, sy in (("right", -1.0), ("left", 1.0)):
    thigh = pelvis.add("body", name=f"{side}_thigh", pos=(0, 0.1 * sy, -0.04))
    _inertial(thigh, 4.7518)
    hinge(thigh, f"{side}_hip_x", (-sy, 0, 0), -10, 10)
    hinge(thigh, f"{side}_hip_y", (0, 1, 0), -30, 70)
    hinge(thigh, f"{side}_hip_z", (0, 0, -sy), -10, 10)
    thigh.add("geom", name=f"{side}_thigh1", type="capsule", fromto=(0, 0, 0, 0, -0.01 * sy, -0.34),
              size=0.06, mass=0)
    shin = thigh.add("body", name=f"{side}_shin", pos=(0, -0.01 * sy, -0.403))
    _inertial(shin, 4.5228)  # 0.02 m below the knee, at the frame origin
    hinge(shin, f"{side}_knee", (0, -1, 0), -160, -2, pos=(0, 0, 0.02))
    default[f"{side}_knee"] = deg(-25)
    shin.add("geom", name=f"{side}_shin1", type="capsule", fromto=(0, 0, 0, 0, 0, -0.3), size=0.049,
             mass=0)
    shin.add("geom", name=f"{side}_shin_end", type="sphere", pos=(0, 0, -0.3), size=0.049, mass=0)
    shin.add("geom", name=f"{side}_foot", type="sphere", pos=(0, 0, -0.35), size=0.075, mass=0)
    colliders += [f"{side}_shin_end", f"{side}_foot"]
  for side, sy in (("right", -1.0), ("left", 1.0)):
    upper = torso.add("body", name=f"{side}_upper_arm", pos=(0, 0.17 * sy, 0.06))
    _inertial(upper, 1.6611)
    lo, hi = (-85, 60) if side == "right" else (-60, 85)
    hinge(upper, f"{side}_shoulder1", (2, -sy, 1), lo, hi)
    hinge(upper, f"{side}_shoulder2", (0, sy, 1), lo, hi)
    upper.add("geom", name=f"{side}_uarm1", type="capsule",
              fromto=(0, 0, 0, 0.16, 0.16 * sy, -0.16), size=0.04, mass=0)
    lower = upper.add("body", name=f"{side}_lower_arm", pos=(0.18, 0.18 * sy, -0.18))
    _inertial(lower, 1.2295)
    hinge(lower, f"{side}_elbow", (0, -1, sy), -90, 50)
    lower.add("geom", name=f"{side}_larm", type="capsule",
              fromto=(0.01, 0.01 * sy, 0.01, 0.17, 0.17 * sy, 0.17), size=0.031, mass=0)
    lower.add("geom", name=f"{side}_hand", type="sphere", pos=(0.18, 0.18 * sy, 0.18), size=0.04,
              mass=0)
  strength = dict(abdomen_z=300, abdomen_y=300, abdomen_x=300, right_hip_x=300, right_hip_y=300,
                  right_hip_z=300, right_knee=300, left_hip_x=300, left_hip_y=300, left_hip_z=300,
                  left_knee=300, right_shoulder1=75, right_shoulder2=75, right_elbow=75,
                  left_shoulder1=75, left_shoulder2=75, left_elbow=75)
  return ComponentSpec(
      bodies=(torso,),
      motors=tuple((j, float(g)) for j, g in strength.items()),
      root="torso",
      root_linear={-1: "root"},
      colliders=tuple(colliders),
      root_colliders=(),
      observers=("root_z_joints",),
      termination=Termination(min_z=0.65, max_z=2.1),
      default_qpos=default,
      rest_on_ground=True,
      torque_cut=True,
      contact_bodies=("right_shin", "left_shin"),
      contact_clip=None,
  )
