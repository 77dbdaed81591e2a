"""Reward terms of a composed scene.

A term is declared in a desc as ``reward_fns={name: dict(reward_type=..., **kwargs)}`` on a component
(one owner) or an edge (two owners). Each raw term gives ``(r, done)``; the wrapper keywords
``scale=1, offset=0, done_bonus=0, exclude_from_score=False`` turn it into

    reward = (r + offset) * scale  (+ done_bonus when done)
    score  = r * sign(scale)       (+ done_bonus when done; 0 when exclude_from_score)

so the score is the un-offset raw term, comparable across scalings (Braxlines' convention).

Raw terms (x is a root quantity, ``sdcomp`` in pos/vel/ang, optionally ``indices``; for an edge x is
the difference of the two roots' quantities):

=============  ======  ===========================================================================
reward_type    owners  r
=============  ======  ===========================================================================
root_goal      1       -||x[indices] - target_goal||  (a scalar target broadcasts)
root_dist      2       -||pos(a) - pos(b)||, done if outside [min_dist, max_dist]
distance       2       -||x(a)[indices] - x(b)[indices]||, done if outside [min_dist, max_dist]
norm           1 or 2  -||x[indices]||, done if outside [min_dist, max_dist]
exp_norm       1 or 2  exp(-||x[indices]||), done if outside [min_dist, max_dist]
forward        1       root velocity along world ``axis`` (default x)
control        1 or 2  -||a||, the owners' actions
constant       any     value
direction      2       max(0, v0 . (sign * v1 / ||v1||)) on the xy velocities (``indices``) of the
                       mover (0) and the other (1); ``sign`` defaults to -1
=============  ======  ===========================================================================

On an edge, ``of=<component>`` makes a one-owner term (``root_goal``, ``norm``, ``exp_norm``,
``forward``, ``control``) about that one of the two components, so an edge can hold, say, the
term "agent0 is pushed out of the ring" that agent1 claims; for ``direction`` it names the mover
(default: the edge's first component).

``direction`` is Braxlines' sumo term. The original gates it on both roots moving towards each
other, but its gate tests the sign of each dot product for truth, so only an exactly zero product
closes it; blx keeps that behaviour (and returns 0 where ||v1|| = 0, where the original divides by
zero).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Sequence

import jax.numpy as jnp
import numpy as np

from blx.envs.observers import SDCOMPS, Handle, root_quantity
from blx.options import check_names, finite_number, keyword_names

__all__ = ["RewardTerm", "build_reward_term", "REWARD_TYPES", "WRAPPER_KEYS"]

WRAPPER_KEYS = ("scale", "offset", "done_bonus", "exclude_from_score")
RawFn = Callable[[Any, jnp.ndarray], tuple[jnp.ndarray, jnp.ndarray]]


def _axes(where: str, indices: Any, sdcomp: str) -> np.ndarray:
  if sdcomp not in SDCOMPS or sdcomp == "rot":
    raise ValueError(f"{where}: sdcomp {sdcomp!r} is not valid; valid values are ['ang', 'pos', 'vel']")
  if indices is None:
    return np.arange(3, dtype=np.int32)
  if isinstance(indices, int) and not isinstance(indices, bool):
    indices = (indices,)
  if (not isinstance(indices, (tuple, list)) or not indices
      or not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < 3 for i in indices)):
    raise ValueError(f"{where}: indices={indices!r} are not valid; use None or a tuple of ints in 0..2")
  return np.asarray(indices, np.int32)


def _quantity(owners: Sequence[Handle], sdcomp: str, axes: np.ndarray) -> Callable:
  if len(owners) == 1:
    return lambda d: root_quantity(owners[0], d, sdcomp)[axes]
  first, second = owners
  return lambda d: (root_quantity(first, d, sdcomp) - root_quantity(second, d, sdcomp))[axes]


def _bounded(value: jnp.ndarray, dist: jnp.ndarray, min_dist: float, max_dist: float):
  return value, (dist < min_dist) | (dist > max_dist)


def _never(value):
  return value, jnp.zeros((), bool)


def root_goal(owners, where, *, sdcomp: str = "pos", indices=None, target_goal=0.0) -> RawFn:
  axes = _axes(where, indices, sdcomp)
  bad = ValueError(f"{where}: target_goal={target_goal!r} must be a finite number or have one "
                   f"finite number per index ({len(axes)})")
  try:
    target = np.asarray(target_goal, np.float32)
  except (TypeError, ValueError):
    raise bad from None
  if (target.ndim > 1 or (target.ndim == 1 and target.shape[0] != len(axes))
      or not np.all(np.isfinite(target))):
    raise bad
  x = _quantity(owners, sdcomp, axes)
  return lambda d, a: _never(-jnp.linalg.norm(x(d) - target))


def distance(owners, where, *, sdcomp: str = "pos", indices=None, min_dist: float = 0.0,
             max_dist: float = math.inf) -> RawFn:
  x = _quantity(owners, sdcomp, _axes(where, indices, sdcomp))

  def fn(d, a):
    dist = jnp.linalg.norm(x(d))
    return _bounded(-dist, dist, min_dist, max_dist)
  return fn


def root_dist(owners, where, *, min_dist: float = 0.0, max_dist: float = math.inf) -> RawFn:
  return distance(owners, where, sdcomp="pos", indices=None, min_dist=min_dist, max_dist=max_dist)


def norm(owners, where, *, sdcomp: str = "vel", indices=None, min_dist: float = 0.0,
         max_dist: float = math.inf) -> RawFn:
  return distance(owners, where, sdcomp=sdcomp, indices=indices, min_dist=min_dist,
                  max_dist=max_dist)


def exp_norm(owners, where, *, sdcomp: str = "vel", indices=None, min_dist: float = 0.0,
             max_dist: float = math.inf) -> RawFn:
  x = _quantity(owners, sdcomp, _axes(where, indices, sdcomp))

  def fn(d, a):
    dist = jnp.linalg.norm(x(d))
    return _bounded(jnp.exp(-dist), dist, min_dist, max_dist)
  return fn


def forward(owners, where, *, axis: int = 0) -> RawFn:
  if axis not in (0, 1, 2):
    raise ValueError(f"{where}: axis={axis!r} is not valid; valid values are 0, 1, 2")
  owner = owners[0]
  return lambda d, a: _never(root_quantity(owner, d, "vel")[axis])


def control(owners, where) -> RawFn:
  idx = np.concatenate([o.actions for o in owners]).astype(np.int32)
  if idx.size == 0:
    raise ValueError(f"{where}: reward_type 'control' needs an actuated owner; "
                     f"{[o.name for o in owners]} have no motors")
  return lambda d, a: _never(-jnp.linalg.norm(a[idx]))


def constant(owners, where, *, value: float = 1.0) -> RawFn:
  value = finite_number(f"{where}.value", value)
  return lambda d, a: _never(jnp.asarray(value, jnp.float32))


def direction(owners, where, *, indices=(0, 1), sign: float = -1.0) -> RawFn:
  axes = _axes(where, indices, "vel")
  sign = float(np.sign(finite_number(f"{where}.sign", sign)))
  mover, other = owners

  def fn(d, a):
    v0, v1 = (root_quantity(o, d, "vel")[axes] for o in (mover, other))
    p0, p1 = (root_quantity(o, d, "pos")[axes] for o in (mover, other))
    gate = (jnp.dot(p1 - p0, v0) != 0) & (jnp.dot(p0 - p1, v1) != 0)
    speed = jnp.linalg.norm(v1)
    unit = v1 / jnp.where(speed > 0, speed, 1.0)
    return _never(jnp.where(gate, jnp.maximum(jnp.dot(v0, sign * unit), 0.0), 0.0))
  return fn


# reward_type -> (builder, allowed owner counts)
REWARD_TYPES: dict[str, tuple[Callable[..., RawFn], tuple[int, ...]]] = {
    "root_goal": (root_goal, (1,)),
    "root_dist": (root_dist, (2,)),
    "distance": (distance, (2,)),
    "norm": (norm, (1, 2)),
    "exp_norm": (exp_norm, (1, 2)),
    "forward": (forward, (1,)),
    "control": (control, (1, 2)),
    "constant": (constant, (1, 2)),
    "direction": (direction, (2,)),
}


@dataclasses.dataclass(frozen=True, eq=False)
class RewardTerm:
  """A wrapped reward term: ``fn(data, action) -> (reward, score, done)``."""

  name: str
  fn: Callable[[Any, jnp.ndarray], tuple[jnp.ndarray, jnp.ndarray, jnp.ndarray]]


def build_reward_term(name: str, spec: Any, owners: Sequence[Handle], where: str) -> RewardTerm:
  """Builds the term ``name`` from its desc ``spec`` for one (component) or two (edge) owners."""
  if not isinstance(spec, dict):
    raise ValueError(f"{where}: a reward term is a dict with 'reward_type', got {spec!r}")
  kwargs = dict(spec)
  reward_type = kwargs.pop("reward_type", None)
  if reward_type not in REWARD_TYPES:
    raise ValueError(f"{where}: unknown reward_type {reward_type!r}; valid reward types are "
                     f"{sorted(REWARD_TYPES)}")
  builder, counts = REWARD_TYPES[reward_type]
  if "of" in kwargs:
    of, names = kwargs.pop("of"), [o.name for o in owners]
    if len(owners) != 2 or of not in names:
      raise ValueError(f"{where}.of: {of!r} is not one of the edge's components; 'of' is for edge "
                       f"terms and names one of their two components"
                       + (f", here {names}" if len(owners) == 2 else ""))
    chosen = owners[names.index(of)]
    # One-owner terms become about ``of`` alone; two-owner terms (direction) take it first.
    owners = [chosen] if 1 in counts else [chosen] + [o for o in owners if o is not chosen]
  if len(owners) not in counts:
    kind = "an edge" if len(owners) == 2 else "a component"
    raise ValueError(f"{where}: reward_type {reward_type!r} cannot be used on {kind}; it takes "
                     f"{' or '.join(map(str, counts))} owner(s)")
  scale = finite_number(f"{where}.scale", kwargs.pop("scale", 1.0))
  offset = finite_number(f"{where}.offset", kwargs.pop("offset", 0.0))
  done_bonus = finite_number(f"{where}.done_bonus", kwargs.pop("done_bonus", 0.0))
  excluded = bool(kwargs.pop("exclude_from_score", False))
  check_names(f"{where} (reward_type {reward_type!r})", kwargs,
              keyword_names(builder, keyword_only=True), "key",
              extra_valid=sorted(WRAPPER_KEYS) + ["reward_type", "of"])
  raw = builder(owners, where, **kwargs)
  sign = float(np.sign(scale))

  def fn(data, action):
    r, done = raw(data, action)
    bonus = jnp.where(done, done_bonus, 0.0)
    reward = (r + offset) * scale + bonus
    score = jnp.zeros_like(r) if excluded else r * sign + bonus
    return reward, score, done
  return RewardTerm(name, fn)
