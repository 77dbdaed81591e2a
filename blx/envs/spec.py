"""What a component contributes to a scene: ``ComponentSpec`` and its termination rule."""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping

from blx.envs.mjcf import Element

__all__ = ["ComponentSpec", "Termination", "MIN_LEGS", "MAX_LEGS"]

MIN_LEGS = 2
MAX_LEGS = 16


@dataclasses.dataclass(frozen=True)
class Termination:
  """Episode end from the root body's pose: height outside ``[min_z, max_z]`` or flipped upside down.

  ``z_offset`` (``term_params`` in a desc) shifts both bounds, e.g. for an ant standing on a ball.
  """

  min_z: float = -math.inf
  max_z: float = math.inf
  check_flip: bool = False


@dataclasses.dataclass(frozen=True)
class ComponentSpec:
  """What a component contributes to a scene (names unprefixed).

  Attributes:
    bodies: top-level MJCF ``body`` elements.
    motors: ``(joint_name, gear)`` for each actuated joint, in action order; actions lie in [-1, 1].
    root: name of the root body.
    root_linear: ``{axis: joint}`` giving the root's linear velocity along world axis 0/1/2; a free
      joint is written ``{-1: joint}`` and gives all three (and the angular velocity).
    root_angular: ``{axis: hinge_joint}`` for planar roots.
    colliders: geoms that take part in contacts (explicit pairs, see the composer).
    root_colliders: the subset of ``colliders`` on the root body (edge ``collide_type='root'``).
    observers: default observers (see ``blx.envs.observers``).
    termination: the rule for ending an episode, or None.
    planar_axes: world axes the root can translate along (``(0, 1)`` for free bodies).
    friction: sliding friction of this component's colliders.
    default_qpos: ``{joint: angle}`` (radians) of the reset pose; other joints start at 0.
    rest_on_ground: lift the reset pose so its lowest collider touches the component's frame z
      (Brax v1 did this for every body; blx leaves ``REST_CLEARANCE``, 1 mm, in between); needs a
      free or z-slide root.
    torque_cut: zero a motor's torque while its joint is outside its range (Brax v1's motors).
    contact_bodies: the bodies the ``"cfrc"`` observer reports, in order.
    contact_clip: the ``"cfrc"`` values are clipped to +-contact_clip (None: unclipped).
  """

  bodies: tuple[Element, ...]
  motors: tuple[tuple[str, float], ...]
  root: str
  root_linear: Mapping[int, str]
  root_angular: Mapping[int, str] = dataclasses.field(default_factory=dict)
  colliders: tuple[str, ...] = ()
  root_colliders: tuple[str, ...] = ()
  observers: tuple[Any, ...] = ("root_z_joints",)
  termination: Termination | None = None
  planar_axes: tuple[int, ...] = (0, 1)
  friction: float = 1.0
  default_qpos: Mapping[str, float] = dataclasses.field(default_factory=dict)
  rest_on_ground: bool = False
  torque_cut: bool = False
  contact_bodies: tuple[str, ...] = ()
  contact_clip: float | None = None

  @property
  def root_joints(self) -> tuple[str, ...]:
    return tuple(self.root_linear.values()) + tuple(self.root_angular.values())
