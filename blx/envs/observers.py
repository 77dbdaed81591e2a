"""Observers: named slices of the observation, read from ``mjx.Data``.

Component observers (``observers`` in a component desc):

* ``"root_joints"``: root position (3), root quaternion (4), joint angles, root linear velocity (3,
  world frame), root angular velocity (3), joint velocities.
* ``"root_z_joints"``: the same with the root position reduced to its height, so the observation is
  invariant to translation in the plane. For the ant this is the classic layout
  ``[z, quat, 8 joint angles, vel xyz, ang xyz, 8 joint velocities]``: x/y velocity at (13, 14).
* ``"qp"``: root position, quaternion, linear and angular velocity (for single-body objects).
* ``"joints"``: joint angles and velocities only.
* ``"actuator"``: what each of the component's motors applied over the last step, in action order
  (MJCF ``actuator_force``; blx's motors have gain 1, so this is the action after the torque cut).
  Brax v1's humanoid observes its motors' torques, action times strength: the same up to a scale
  per motor, which PPO's observation normaliser removes. The registered ``humanoid`` env observes
  them (``blx.envs.descs.HUMANOID_OBSERVERS``); the ``humanoid`` component, alone, does not.
* ``"cfrc"``: the contact velocity change of each of the component's ``contact_bodies`` over the last
  step, Δv (3 per body) then Δω (3 per body), world frame, clipped to +-``contact_clip`` (Brax v1's
  ``info.contact``, which its ant and humanoid observe; computed from MJX's contact forces, see
  ``blx.envs.brax_bodies``). The ants observe it by default, and the registered ``humanoid`` env
  its shins'; the ``humanoid`` component, alone, does not.
* ``"com"``: the rest of Brax v0.0.6's humanoid observation, functions of the state about the
  component's centre of mass. For each of the component's bodies b, with m_b its mass, M the
  component's, d_b the offset of b's centre of mass from the component's and v_b its velocity
  (world frame): the inertia about that centre, I_b + m_b (|d_b|² I - d_b d_bᵀ) (9 per body, I_b
  the body's principal inertia unrotated, as Brax's, whose humanoid's are all 1 I_3), then
  v_b m_b / M (3 per body), then d_b × v_b / (|d_b|² + 1e-7) (3 per body): 15 per body, 165 for
  the humanoid's 11. Computed from the state's positions and velocities (not from ``mjx.Data``'s
  kinematics, which ``mjx.step`` leaves one substep behind). An option: no registered env observes
  it.
* ``dict(observer_type="root", sdcomp="pos"|"rot"|"vel"|"ang", indices=None)``: one root quantity,
  optionally indexed.

Edge observers (``extra_observers`` of an edge ``"a__b"``):

* ``dict(observer_type="root_vec", sdcomp="pos", indices=None)``: root(a) - root(b).

Root angular velocities are in the world frame (MuJoCo's free joint stores them in the body frame;
they are rotated here), as in Brax.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Sequence

import jax.numpy as jnp
import numpy as np

__all__ = ["ObsPiece", "Handle", "root_quantity", "component_observers", "edge_observers",
           "contact_observer", "com_observer",
           "COMPONENT_OBSERVERS", "EDGE_OBSERVERS", "SDCOMPS"]

COMPONENT_OBSERVERS = ("root_joints", "root_z_joints", "qp", "joints", "cfrc", "actuator", "com",
                       "root")
EDGE_OBSERVERS = ("root_vec",)
SDCOMPS = {"pos": 3, "rot": 4, "vel": 3, "ang": 3}


@dataclasses.dataclass(frozen=True, eq=False)
class Handle:
  """A component resolved against the compiled model: indices into ``mjx.Data`` arrays."""

  name: str
  body: int
  lin_axes: tuple[int, ...]      # world axes with a linear velocity dof
  lin_dofs: tuple[int, ...]      # qvel addresses, aligned with lin_axes
  ang_axes: tuple[int, ...]
  ang_dofs: tuple[int, ...]
  free_qpos: int | None          # qpos address of a free root joint
  pos0: np.ndarray               # root position and orientation at qpos0 (world frame)
  quat0: np.ndarray
  slide_qpos: tuple[int, ...]    # qpos addresses of root slides, aligned with lin_axes
  hinge_qpos: tuple[int, ...]    # qpos addresses of root hinges, aligned with ang_axes
  joint_qpos: np.ndarray         # qpos addresses of non-root joints
  joint_qvel: np.ndarray         # qvel addresses of non-root joints
  actions: np.ndarray            # indices of this component's motors in the action vector
  planar_axes: tuple[int, ...]
  joint_names: tuple[str, ...]   # the non-root joints' MJCF names, aligned with joint_qpos


def _scatter3(values: jnp.ndarray, axes: Sequence[int]) -> jnp.ndarray:
  out = jnp.zeros(3, values.dtype)
  return out.at[np.asarray(axes, dtype=np.int32)].set(values) if axes else out


def _quat_mul(a: jnp.ndarray, b: jnp.ndarray) -> jnp.ndarray:
  aw, ax, ay, az = a
  bw, bx, by, bz = b
  return jnp.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                    aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _rotate(quat: jnp.ndarray, v: jnp.ndarray) -> jnp.ndarray:
  """Rotates ``v`` by the unit quaternion ``quat`` (wxyz)."""
  w, xyz = quat[0], quat[1:]
  t = 2.0 * jnp.cross(xyz, v)
  return v + w * t + jnp.cross(xyz, t)


def root_quantity(handle: Handle, data: Any, sdcomp: str) -> jnp.ndarray:
  """The root's position [3], orientation quaternion [4], linear [3] or angular [3] velocity.

  Read from ``qpos``/``qvel`` (not ``xpos``, which ``mjx.step`` leaves one substep behind), so
  positions and velocities in an observation belong to the same instant.
  """
  if sdcomp == "pos":
    if handle.free_qpos is not None:
      return data.qpos[handle.free_qpos:handle.free_qpos + 3]
    pos = jnp.asarray(handle.pos0, data.qpos.dtype)
    if handle.slide_qpos:
      pos = pos.at[np.asarray(handle.lin_axes)].add(data.qpos[np.asarray(handle.slide_qpos)])
    return pos
  if sdcomp == "rot":
    if handle.free_qpos is not None:
      return data.qpos[handle.free_qpos + 3:handle.free_qpos + 7]
    quat = jnp.asarray(handle.quat0, data.qpos.dtype)
    for axis, adr in zip(handle.ang_axes, handle.hinge_qpos):
      half = 0.5 * data.qpos[adr]
      rot = jnp.zeros(4, quat.dtype).at[0].set(jnp.cos(half)).at[axis + 1].set(jnp.sin(half))
      quat = _quat_mul(rot, quat)
    return quat
  if sdcomp == "vel":
    return _scatter3(data.qvel[np.asarray(handle.lin_dofs, np.int32)], handle.lin_axes)
  if sdcomp == "ang":
    if handle.free_qpos is not None:  # qvel holds the body-frame angular velocity: rotate to world
      local = data.qvel[handle.ang_dofs[0]:handle.ang_dofs[0] + 3]
      return _rotate(data.qpos[handle.free_qpos + 3:handle.free_qpos + 7], local)
    return _scatter3(data.qvel[np.asarray(handle.ang_dofs, np.int32)], handle.ang_axes)
  raise ValueError(f"unknown sdcomp {sdcomp!r}; valid values are {sorted(SDCOMPS)}")


@dataclasses.dataclass(frozen=True, eq=False)
class ObsPiece:
  """One named slice of the observation.

  ``source`` is ``(owner, sdcomp, axes)`` for root quantities (used to resolve named index sets such
  as ``"vel_xy"``), otherwise None.
  """

  name: str
  size: int
  fn: Callable[[Any], jnp.ndarray]
  source: tuple[str, str, tuple[int, ...]] | None = None
  reads_contact: bool = False   # fn reads the env's contact array ``[B, 6]`` instead of mjx.Data


def contact_observer(comp: str, rows: np.ndarray, clip: float | None) -> list[ObsPiece]:
  """Δv then Δω of the contact array's ``rows`` (one component's bodies), optionally clipped."""
  bound = (lambda x: jnp.clip(x, -clip, clip)) if clip is not None else (lambda x: x)
  return [ObsPiece(f"{comp}/contact_vel", 3 * len(rows), lambda c: bound(c[rows, :3]),
                   reads_contact=True),
          ObsPiece(f"{comp}/contact_ang", 3 * len(rows), lambda c: bound(c[rows, 3:]),
                   reads_contact=True)]


def com_observer(comp: str, mj_model: Any, mjx_model: Any, bodies: np.ndarray) -> ObsPiece:
  """The ``"com"`` observer of the component ``comp`` whose bodies are ``bodies`` (ids in
  ``mj_model``): per body, its inertia about the component's centre of mass [9], its momentum share
  v m / M [3], and d × v / (|d|² + 1e-7) [3], blocked as Brax's humanoid had them (every body's
  inertia, then every body's momentum share, then every body's last part)."""
  from mujoco import mjx  # here, not at the top: the observers' other readers need no MJX
  bodies = np.asarray(bodies, np.int32)
  mass = np.asarray(mj_model.body_mass, np.float32)[bodies]
  total = float(mass.sum())
  if total <= 0:
    raise ValueError(f"the 'com' observer of {comp!r}: its bodies have no mass")
  inertia = np.stack([np.diag(i) for i in np.asarray(mj_model.body_inertia, np.float32)[bodies]])
  roots = np.asarray(mj_model.body_rootid, np.int32)[bodies]

  def fn(data):
    data = mjx.com_vel(mjx_model, mjx.com_pos(mjx_model, mjx.kinematics(mjx_model, data)))
    pos = data.xipos[bodies]
    ang, lin = data.cvel[bodies, :3], data.cvel[bodies, 3:]
    vel = lin + jnp.cross(ang, pos - data.subtree_com[roots])   # at each body's centre of mass
    disp = pos - (mass[:, None] * pos).sum(0) / total
    square = (disp * disp).sum(-1)
    about = inertia + mass[:, None, None] * (square[:, None, None] * jnp.eye(3)
                                             - disp[:, :, None] * disp[:, None, :])
    return jnp.concatenate([about.reshape(-1), (vel * mass[:, None] / total).reshape(-1),
                            (jnp.cross(disp, vel) / (square + 1e-7)[:, None]).reshape(-1)])

  return ObsPiece(f"{comp}/com", 15 * len(bodies), fn)


def _indices(where: str, indices: Any, size: int) -> tuple[int, ...]:
  if indices is None:
    return tuple(range(size))
  if isinstance(indices, int) and not isinstance(indices, bool):
    indices = (indices,)
  if (not isinstance(indices, (tuple, list)) or not indices
      or not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < size for i in indices)):
    raise ValueError(f"{where}: indices={indices!r} are not valid; use None or a non-empty tuple of "
                     f"ints in 0..{size - 1}")
  return tuple(indices)


def _suffix(axes: tuple[int, ...], size: int) -> str:
  return "" if axes == tuple(range(size)) else "[" + ",".join(map(str, axes)) + "]"


def _root_piece(handle: Handle, sdcomp: str, axes: tuple[int, ...], name: str) -> ObsPiece:
  idx = np.asarray(axes, np.int32)
  suffix = "" if name == "root_z" else _suffix(axes, SDCOMPS[sdcomp])
  return ObsPiece(f"{handle.name}/{name}{suffix}", len(axes),
                  lambda d: root_quantity(handle, d, sdcomp)[idx],
                  (handle.name, sdcomp, axes) if sdcomp in ("pos", "vel") else None)


def _joint_pieces(handle: Handle, which: str) -> list[ObsPiece]:
  if which == "pos":
    adr = handle.joint_qpos
    return [ObsPiece(f"{handle.name}/joint_pos", len(adr), lambda d: d.qpos[adr])] if len(adr) else []
  adr = handle.joint_qvel
  return [ObsPiece(f"{handle.name}/joint_vel", len(adr), lambda d: d.qvel[adr])] if len(adr) else []


def component_observers(handle: Handle, observer: Any, where: str) -> list[ObsPiece]:
  """Resolves one component observer spec into observation pieces."""
  root = lambda sd, name, axes=None: _root_piece(handle, sd, axes or tuple(range(SDCOMPS[sd])), name)
  if observer in ("root_joints", "root_z_joints"):
    position = root("pos", "root_z", (2,)) if observer == "root_z_joints" else root("pos", "root_pos")
    return [position, root("rot", "root_quat"), *_joint_pieces(handle, "pos"),
            root("vel", "root_vel"), root("ang", "root_ang"), *_joint_pieces(handle, "vel")]
  if observer == "qp":
    return [root("pos", "root_pos"), root("rot", "root_quat"), root("vel", "root_vel"),
            root("ang", "root_ang")]
  if observer == "joints":
    return [*_joint_pieces(handle, "pos"), *_joint_pieces(handle, "vel")]
  if observer == "actuator":
    adr = np.asarray(handle.actions, np.int32)
    if not len(adr):
      raise ValueError(f"{where}: component {handle.name!r} has no motors; the 'actuator' observer "
                       "reads the forces of a component's motors")
    return [ObsPiece(f"{handle.name}/actuator_force", len(adr), lambda d: d.actuator_force[adr])]
  if isinstance(observer, dict):
    spec = dict(observer)
    kind = spec.pop("observer_type", None)
    if kind != "root":
      raise ValueError(f"{where}: unknown observer_type {kind!r}; valid component observer types "
                       f"are ['root'] (or one of the strings {list(COMPONENT_OBSERVERS[:-1])})")
    sdcomp = spec.pop("sdcomp", "pos")
    indices = spec.pop("indices", None)
    if spec:
      raise ValueError(f"{where}: unknown observer keys {sorted(spec)}; valid keys are "
                       "['observer_type', 'sdcomp', 'indices']")
    if sdcomp not in SDCOMPS:
      raise ValueError(f"{where}: unknown sdcomp {sdcomp!r}; valid values are {sorted(SDCOMPS)}")
    name = {"pos": "root_pos", "rot": "root_quat", "vel": "root_vel", "ang": "root_ang"}[sdcomp]
    return [root(sdcomp, name, _indices(where, indices, SDCOMPS[sdcomp]))]
  raise ValueError(f"{where}: unknown observer {observer!r}; valid observers are "
                   f"{list(COMPONENT_OBSERVERS[:-1])} or dict(observer_type='root', sdcomp=..., "
                   "indices=...)")


def edge_observers(edge: str, first: Handle, second: Handle, observer: Any,
                   where: str) -> list[ObsPiece]:
  """Resolves one edge observer spec (``root_vec``: root(first) - root(second))."""
  if not isinstance(observer, dict):
    raise ValueError(f"{where}: edge observers are dicts such as dict(observer_type='root_vec'), "
                     f"got {observer!r}")
  spec = dict(observer)
  kind = spec.pop("observer_type", None)
  if kind not in EDGE_OBSERVERS:
    raise ValueError(f"{where}: unknown observer_type {kind!r}; valid edge observer types are "
                     f"{list(EDGE_OBSERVERS)}")
  sdcomp = spec.pop("sdcomp", "pos")
  indices = spec.pop("indices", None)
  if spec:
    raise ValueError(f"{where}: unknown observer keys {sorted(spec)}; valid keys are "
                     "['observer_type', 'sdcomp', 'indices']")
  if sdcomp not in ("pos", "vel", "ang"):
    raise ValueError(f"{where}: sdcomp {sdcomp!r} is not valid for root_vec; valid values are "
                     "['ang', 'pos', 'vel']")
  axes = _indices(where, indices, 3)
  idx = np.asarray(axes, np.int32)
  fn = lambda d: (root_quantity(first, d, sdcomp) - root_quantity(second, d, sdcomp))[idx]
  return [ObsPiece(f"{edge}/root_vec_{sdcomp}{_suffix(axes, 3)}", len(axes), fn)]
