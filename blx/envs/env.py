"""``Env``: a composed scene compiled once to MJX, with pure ``reset`` and ``step``."""

from __future__ import annotations

from typing import Any, Mapping

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import mjx

from blx.envs.composer import compose
from blx.envs.observers import (Handle, ObsPiece, component_observers, edge_observers,
                                root_quantity)
from blx.envs.rewards import RewardTerm, build_reward_term

__all__ = ["Env", "State"]


@struct.dataclass
class State:
  """Environment state, a pytree.

  Attributes:
    data: ``mjx.Data`` of the scene.
    obs: observation ``[observation_size]``.
    reward: scalar reward of the last step.
    done: 1.0 when the episode ended at the last step (termination or truncation), else 0.0.
    metrics: ``reward/<term>`` and ``score/<term>`` for every reward term, and ``score``.
    info: wrapper bookkeeping (``steps``, ``truncation``, first state for auto-reset).
  """

  data: mjx.Data
  obs: jax.Array
  reward: jax.Array
  done: jax.Array
  metrics: dict[str, jax.Array] = struct.field(default_factory=dict)
  info: dict[str, Any] = struct.field(default_factory=dict)


_AXES = {"x": 0, "y": 1, "z": 2}


class Env:
  """A composed environment (see ``blx.envs.create``).

  The MJCF is compiled by MuJoCo and put on the device once, in the constructor; ``reset`` and
  ``step`` are pure functions of arrays that work under ``jax.jit`` and ``jax.vmap``. One env step
  runs ``substeps`` physics steps.

  Attributes:
    name: registered name, or None for a desc built by hand.
    desc: the validated desc (a deep copy).
    xml: the MJCF string (deterministic for a desc).
    mj_model / mjx_model: the compiled MuJoCo model and its MJX copy.
    observation_size, action_size: sizes of observation and action vectors; actions lie in [-1, 1].
    obs_layout: ``{name: slice}`` naming every slice of the observation.
    reward_terms: names of the reward terms (``<component>/<name>``, ``<a>__<b>/<name>``).
    dt: seconds of simulated time per env step.
  """

  def __init__(self, desc: Mapping[str, Any], *, name: str | None = None):
    scene = compose(desc)
    self.name = name
    self.desc = scene.desc
    self.xml = scene.xml
    self.options = scene.options
    self.substeps = int(scene.options["substeps"])
    self.mj_model = mujoco.MjModel.from_xml_string(self.xml)
    self.mjx_model = mjx.put_model(self.mj_model)
    self.dt = float(self.mj_model.opt.timestep) * self.substeps
    self.action_size = int(self.mj_model.nu)

    rest = mujoco.MjData(self.mj_model)
    mujoco.mj_forward(self.mj_model, rest)  # world pose of every body at qpos0, shared by all
    self._handles = {n: self._resolve(n, spec, rest) for n, spec in scene.specs.items()}
    comps = self.desc["components"]
    pieces: list[ObsPiece] = []
    terms: list[RewardTerm] = []
    for n, spec in scene.specs.items():
      observers = comps[n].get("observers", spec.observers)
      for i, obs in enumerate(observers):
        pieces += component_observers(self._handles[n], obs, f"components.{n}.observers[{i}]")
      for term, term_desc in comps[n].get("reward_fns", {}).items():
        terms.append(build_reward_term(f"{n}/{term}", term_desc, [self._handles[n]],
                                       f"components.{n}.reward_fns.{term}"))
    for key in sorted(self.desc.get("edges", {}) or {}):
      edge = self.desc["edges"][key]
      first, second = key.split("__")
      if "ground" in (first, second) and (edge.get("extra_observers") or edge.get("reward_fns")):
        raise ValueError(f"edges.{key}: ground has no root; only collide_type may be set")
      owners = [self._handles.get(first), self._handles.get(second)]
      for i, obs in enumerate(edge.get("extra_observers", ())):
        pieces += edge_observers(key, *owners, obs, f"edges.{key}.extra_observers[{i}]")
      for term, term_desc in edge.get("reward_fns", {}).items():
        terms.append(build_reward_term(f"{key}/{term}", term_desc, owners,
                                       f"edges.{key}.reward_fns.{term}"))
    self._pieces = _unique(pieces)
    self._terms = tuple(terms)
    self.reward_terms = tuple(t.name for t in terms)
    layout, start = {}, 0
    for piece in self._pieces:
      layout[piece.name] = slice(start, start + piece.size)
      start += piece.size
    self.obs_layout: dict[str, slice] = layout
    self.observation_size = start
    if start == 0:
      raise ValueError("desc: the scene has no observers; give a component an observer list")

    self._terminations = []
    for n, spec in scene.specs.items():
      rule = spec.termination
      if rule is not None and not comps[n].get("frozen", False):
        offset = float(comps[n].get("term_params", {}).get("z_offset", 0.0))
        self._terminations.append((self._handles[n], rule, offset))
    actuated = [n for n, h in self._handles.items() if len(h.actions)]
    self.main_component = actuated[0] if actuated else next(iter(self._handles))
    self._named = self._named_index_sets()

    # Reset noise applies to non-free joint positions and to all velocities.
    noise_qpos = np.concatenate([h.joint_qpos for h in self._handles.values()] + [np.zeros(0, int)])
    self._noise_qpos = noise_qpos.astype(np.int32)
    self._data0 = mjx.make_data(self.mjx_model)

  # ------------------------------------------------------------------------------------------------
  def _resolve(self, comp: str, spec, rest: mujoco.MjData) -> Handle:
    m = self.mj_model
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"{comp}/{spec.root}")
    jid = lambda j: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{comp}/{j}")
    lin_axes, lin_dofs, slides, ang_axes, ang_dofs, hinges = [], [], [], [], [], []
    free = None

    def check_axis(joint: int, axis: int):
      if not np.allclose(np.abs(rest.xaxis[joint]), np.eye(3)[axis], atol=1e-6):
        raise ValueError(f"component {comp!r}: root joint {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, joint)!r} is "
                         f"not aligned with world axis {axis}; planar components cannot be rotated")

    for axis, joint in spec.root_linear.items():
      j = jid(joint)
      if j < 0:  # frozen: the joint was removed
        continue
      adr = int(m.jnt_dofadr[j])
      if axis == -1:
        free = int(m.jnt_qposadr[j])
        lin_axes, lin_dofs = [0, 1, 2], [adr, adr + 1, adr + 2]
        ang_axes, ang_dofs = [0, 1, 2], [adr + 3, adr + 4, adr + 5]
      else:
        check_axis(j, axis)
        lin_axes.append(axis)
        lin_dofs.append(adr)
        slides.append(int(m.jnt_qposadr[j]))
    for axis, joint in spec.root_angular.items():
      j = jid(joint)
      if j >= 0:
        check_axis(j, axis)
        ang_axes.append(axis)
        ang_dofs.append(int(m.jnt_dofadr[j]))
        hinges.append(int(m.jnt_qposadr[j]))
    root_joints = {f"{comp}/{j}" for j in spec.root_joints}
    qpos, qvel = [], []
    for j in range(m.njnt):
      jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
      if jname.startswith(f"{comp}/") and jname not in root_joints:
        if int(m.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                      int(mujoco.mjtJoint.mjJNT_SLIDE)):
          raise ValueError(f"component {comp!r}: joint {jname!r} is not a hinge or slide; only the "
                           "root may have a free joint")
        qpos.append(int(m.jnt_qposadr[j]))
        qvel.append(int(m.jnt_dofadr[j]))
    actions = [i for i in range(m.nu)
               if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i).startswith(f"{comp}/")]
    # With planar root joints at their zero, the body pose is its pose at qpos0.
    return Handle(comp, body, tuple(lin_axes), tuple(lin_dofs), tuple(ang_axes), tuple(ang_dofs),
                  free, rest.xpos[body].astype(np.float32).copy(),
                  rest.xquat[body].astype(np.float32).copy(), tuple(slides), tuple(hinges),
                  np.asarray(qpos, np.int32), np.asarray(qvel, np.int32),
                  np.asarray(actions, np.int32), tuple(spec.planar_axes))

  def _named_index_sets(self) -> dict[str, tuple[int, ...]]:
    """Every named set ``[<component>/]{pos,vel}_{x,y,z,xy,xyz}`` the observation can serve."""
    found: dict[str, tuple[int, ...]] = {}
    for comp in self._handles:
      for sd in ("pos", "vel"):
        for axes in ("x", "y", "z", "xy", "xyz"):
          idx = self._lookup(comp, sd, axes)
          if idx is not None:
            found[f"{comp}/{sd}_{axes}"] = idx
            if comp == self.main_component:
              found[f"{sd}_{axes}"] = idx
    main = self.main_component
    planar = self._handles[main].planar_axes
    default_vel = "vel_x" if planar == (0,) else "vel_xy"
    if default_vel in found:
      found["vel"] = found[default_vel]
    return found

  def _lookup(self, comp: str, sd: str, axes: str) -> tuple[int, ...] | None:
    wanted = [_AXES[a] for a in axes]
    if sd in ("pos", "vel") and any(a not in self._handles[comp].planar_axes + (2,) for a in wanted):
      return None
    start = 0
    for piece in self._pieces:
      if piece.source is not None and piece.source[:2] == (comp, sd):
        if all(a in piece.source[2] for a in wanted):
          return tuple(start + piece.source[2].index(a) for a in wanted)
      start += piece.size
    return None

  @property
  def named_indices(self) -> dict[str, tuple[int, ...]]:
    """All named index sets, e.g. ``{"vel_xy": (13, 14), "agent1/vel_xy": (13, 14), ...}``."""
    return dict(self._named)

  def obs_indices(self, name: Any) -> tuple[int, ...]:
    """Resolves a named index set to observation indices.

    Accepts a named set (``"vel_xy"``, ``"vel_x"``, ``"pos_xy"``, ``"vel"``, for the main agent;
    ``"cap1/vel_xy"`` for another component), an ``obs_layout`` name (all its indices), a layout name
    with one index (``"agent1/root_vel[1]"``), or a sequence of ints (validated and returned).
    """
    if isinstance(name, (tuple, list)):
      if not name or not all(isinstance(i, int) and 0 <= i < self.observation_size for i in name):
        raise ValueError(f"obs_indices: {name!r} must be ints in 0..{self.observation_size - 1}")
      return tuple(name)
    if not isinstance(name, str):
      raise ValueError(f"obs_indices: expected a name or a tuple of ints, got {name!r}")
    if name in self._named:
      return self._named[name]
    if name in self.obs_layout:
      s = self.obs_layout[name]
      return tuple(range(s.start, s.stop))
    if name.endswith("]") and "[" in name:
      base, _, index = name[:-1].rpartition("[")
      if base in self.obs_layout and index.isdigit():
        s = self.obs_layout[base]
        if int(index) < s.stop - s.start:
          return (s.start + int(index),)
    planar = self._handles[self.main_component].planar_axes
    hint = (f" ({self.main_component} is planar and moves along x only: use 'vel_x')"
            if planar == (0,) and name.endswith(("_xy", "_y", "_xyz")) else "")
    raise ValueError(f"obs_indices: unknown name {name!r}{hint}; named sets are "
                     f"{sorted(self._named)}; layout names are {list(self.obs_layout)}")

  # ------------------------------------------------------------------------------------------------
  def _observe(self, data: mjx.Data) -> jax.Array:
    return jnp.concatenate([jnp.reshape(p.fn(data), (-1,)) for p in self._pieces])

  def _reward(self, data: mjx.Data, action: jax.Array):
    metrics, reward, score, done = {}, jnp.zeros(()), jnp.zeros(()), jnp.zeros((), bool)
    for term in self._terms:
      r, s, d = term.fn(data, action)
      metrics[f"reward/{term.name}"] = r
      metrics[f"score/{term.name}"] = s
      reward, score, done = reward + r, score + s, done | d
    metrics["score"] = score
    for handle, rule, offset in self._terminations:
      z = root_quantity(handle, data, "pos")[2]
      done = done | (z < rule.min_z + offset) | (z > rule.max_z + offset)
      if rule.check_flip:
        w, x, y, _ = root_quantity(handle, data, "rot")
        done = done | (1.0 - 2.0 * (x * x + y * y) < 0.0)  # z of the body's up axis is negative
    return reward, done, metrics

  def reset(self, key: jax.Array) -> State:
    """Initial state: the model's default pose, plus uniform noise of ``reset_noise_scale``."""
    scale = float(self.options["reset_noise_scale"])
    qpos = jnp.asarray(self.mj_model.qpos0, jnp.float32)
    qvel = jnp.zeros(self.mj_model.nv, jnp.float32)
    if scale > 0:
      pos_key, vel_key = jax.random.split(key)
      qpos = qpos.at[self._noise_qpos].add(
          jax.random.uniform(pos_key, (len(self._noise_qpos),), minval=-scale, maxval=scale))
      qvel = scale * jax.random.uniform(vel_key, (self.mj_model.nv,), minval=-1.0, maxval=1.0)
    data = mjx.forward(self.mjx_model, self._data0.replace(qpos=qpos, qvel=qvel))
    metrics = {f"{kind}/{t}": jnp.zeros(()) for t in self.reward_terms for kind in ("reward", "score")}
    metrics["score"] = jnp.zeros(())
    return State(data=data, obs=self._observe(data), reward=jnp.zeros(()), done=jnp.zeros(()),
                 metrics=metrics, info={})

  def step(self, state: State, action: jax.Array) -> State:
    """Advances ``substeps`` physics steps with ``action`` (clipped to [-1, 1]) held fixed."""
    action = jnp.clip(action, -1.0, 1.0)
    data = state.data.replace(ctrl=action)
    data = jax.lax.fori_loop(0, self.substeps, lambda _, d: mjx.step(self.mjx_model, d), data)
    reward, done, metrics = self._reward(data, action)
    return state.replace(data=data, obs=self._observe(data), reward=reward,
                         done=done.astype(jnp.float32), metrics=metrics)

  def __repr__(self) -> str:
    return (f"Env({self.name or 'custom'}: obs {self.observation_size}, action {self.action_size}, "
            f"dt {self.dt:g}s)")


def _unique(pieces: list[ObsPiece]) -> list[ObsPiece]:
  """Makes layout names unique by suffixing repeats with #2, #3, ..."""
  seen: dict[str, int] = {}
  out = []
  for p in pieces:
    seen[p.name] = seen.get(p.name, 0) + 1
    out.append(p if seen[p.name] == 1 else ObsPiece(f"{p.name}#{seen[p.name]}", p.size, p.fn,
                                                   p.source))
  return out
