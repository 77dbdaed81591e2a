"""``Env``: a composed scene compiled once to MJX, with pure ``reset`` and ``step``."""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from blx._mujoco import mujoco  # first: mujoco without its OpenGL backend (only rendering needs GL)
from mujoco import mjx  # noqa: I001
from mujoco.mjx._src import support as mjx_support  # contact_force_dim: forces of condim-3 contacts

from blx.envs.agents import AgentGroups, resolve_agent_groups
from blx.envs.composer import compose
from blx.envs.observers import (Handle, ObsPiece, com_observer, component_observers,
                                contact_observer, edge_observers, root_quantity)
from blx.envs.rewards import RewardTerm, build_reward_term

__all__ = ["Env", "State", "TorqueCut", "REST_CLEARANCE"]


@struct.dataclass
class State:
  """Environment state, a pytree.

  Attributes:
    data: ``mjx.Data`` of the scene.
    obs: observation ``[observation_size]``.
    reward: reward of the last step: a scalar, or ``[num_agents]`` (in ``Env.agent_names`` order)
      for a multi-agent scene.
    done: 1.0 when the episode ended at the last step (termination or truncation), else 0.0.
    metrics: ``reward/<term>`` and ``score/<term>`` for every reward term, and ``score`` (a
      multi-agent scene: ``reward/<agent>/<term>``, ``score/<agent>/<term>``, ``score/<agent>``, and
      ``score``, the sum over agents).
    info: wrapper bookkeeping (``steps``, the first state for auto-reset).
    truncation: 1.0 when the episode ended at the last step because its time ran out (set by the
      ``episode`` wrapper), not because it terminated; learners bootstrap from the value there.
    pre_reset_obs: the observation the last step reached; the same as ``obs`` except after an
      ``auto_reset``, where ``obs`` is already the next episode's first observation.
    contact: ``[B, 6]`` the contact velocity change (Δv, Δω, world frame) of each body that a
      ``"cfrc"`` observer reports, summed over the substeps of the last step; ``[0, 6]`` when none.
  """

  data: mjx.Data
  obs: jax.Array
  reward: jax.Array
  done: jax.Array
  metrics: dict[str, jax.Array] = struct.field(default_factory=dict)
  info: dict[str, Any] = struct.field(default_factory=dict)
  contact: Any = None
  truncation: Any = None
  pre_reset_obs: Any = None


_AXES = {"x": 0, "y": 1, "z": 2}

# Bodies that rest on the floor at reset start this far above it. Brax placed them exactly on it; at
# exactly zero distance float32 MJX and float64 MuJoCo disagree on whether the first contact is
# active (4.6 cm apart after one ant step), while from 1 mm up they agree to 1e-6.
REST_CLEARANCE = 0.001


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
    agents: the resolved ``agent_groups`` (``blx.envs.agents``), or None for a single-agent scene.
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
    self._contact_bodies: list[int] = []   # body ids whose contact Δv/Δω the observation reports
    for n, spec in scene.specs.items():
      observers = comps[n].get("observers", spec.observers)
      for i, obs in enumerate(observers):
        where = f"components.{n}.observers[{i}]"
        if obs == "cfrc":
          pieces += self._contact_pieces(n, spec, where)
        elif obs == "com":
          pieces.append(self._com_piece(n))
        else:
          pieces += component_observers(self._handles[n], obs, where)
      for term, term_desc in comps[n].get("reward_fns", {}).items():
        terms.append(build_reward_term(f"{n}/{term}", term_desc, [self._handles[n]],
                                       f"components.{n}.reward_fns.{term}"))
    for key in sorted(self.desc.get("edges", {}) or {}):
      edge = self.desc["edges"][key]
      first, second = key.split("__")
      owners = [self._handles.get(first), self._handles.get(second)]
      for i, obs in enumerate(edge.get("extra_observers", ())):
        pieces += edge_observers(key, *owners, obs, f"edges.{key}.extra_observers[{i}]")
      for term, term_desc in edge.get("reward_fns", {}).items():
        terms.append(build_reward_term(f"{key}/{term}", term_desc, owners,
                                       f"edges.{key}.reward_fns.{term}"))
    self._pieces = _unique(pieces)
    self._terms = tuple(terms)
    self.reward_terms = tuple(t.name for t in terms)
    groups = self.desc.get("agent_groups")
    self.agents: AgentGroups | None = None if groups is None else resolve_agent_groups(
        groups, self.reward_terms, {n: h.actions for n, h in self._handles.items()})
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
    self.init_qpos = self._default_pose(scene)
    self.torque_cut = self._torque_cut(scene)

  # ------------------------------------------------------------------------------------------------
  def _default_pose(self, scene) -> np.ndarray:
    """qpos of the reset pose: each component's default angles, lifted onto its frame's floor
    (``REST_CLEARANCE`` above it)."""
    m = self.mj_model
    qpos = m.qpos0.copy()
    comps = self.desc["components"]
    for n, spec in scene.specs.items():
      for joint, angle in spec.default_qpos.items():
        j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"{n}/{joint}")
        if j >= 0:
          qpos[m.jnt_qposadr[j]] = angle
    data = mujoco.MjData(m)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(m, data)
    for n, spec in scene.specs.items():
      handle = self._handles[n]
      if not spec.rest_on_ground or comps[n].get("frozen", False) or not spec.colliders:
        continue
      lowest = min(_geom_bottom(m, data, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{n}/{g}"))
                   for g in spec.colliders)
      floor = float(comps[n].get("pos", (0.0, 0.0, 0.0))[2]) + REST_CLEARANCE
      if handle.free_qpos is not None:
        qpos[handle.free_qpos + 2] += floor - lowest
      elif 2 in handle.lin_axes:
        qpos[handle.slide_qpos[handle.lin_axes.index(2)]] += floor - lowest
    return qpos.astype(np.float32)

  def _torque_cut(self, scene) -> "TorqueCut":
    """Motors whose torque Brax v1 zeroes while their joint is outside its range."""
    m = self.mj_model
    ids, adr, lo, hi = [], [], [], []
    for i in range(m.nu):
      comp = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i).split("/")[0]
      joint = int(m.actuator_trnid[i, 0])
      if scene.specs[comp].torque_cut and m.jnt_limited[joint]:
        ids.append(i)
        adr.append(int(m.jnt_qposadr[joint]))
        lo.append(float(m.jnt_range[joint, 0]))
        hi.append(float(m.jnt_range[joint, 1]))
    as_np = lambda x, t: np.asarray(x, t)
    return TorqueCut(as_np(ids, np.int32), as_np(adr, np.int32), as_np(lo, np.float32),
                     as_np(hi, np.float32))

  def _contact_pieces(self, comp: str, spec, where: str) -> list[ObsPiece]:
    if not spec.contact_bodies:
      raise ValueError(f"{where}: component {spec.root!r} of {comp!r} names no contact_bodies; the "
                       "'cfrc' observer is offered by the ant-like bodies and the humanoid")
    rows = []
    for body in spec.contact_bodies:
      b = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, f"{comp}/{body}")
      rows.append(len(self._contact_bodies))
      self._contact_bodies.append(b)
    return contact_observer(comp, np.asarray(rows, np.int32), spec.contact_clip)

  def _com_piece(self, comp: str) -> ObsPiece:
    m = self.mj_model
    bodies = [b for b in range(m.nbody)
              if (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or "").startswith(f"{comp}/")]
    return com_observer(comp, m, self.mjx_model, np.asarray(bodies, np.int32))

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
    qpos, qvel, names = [], [], []
    for j in range(m.njnt):
      jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
      if jname.startswith(f"{comp}/") and jname not in root_joints:
        if int(m.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                      int(mujoco.mjtJoint.mjJNT_SLIDE)):
          raise ValueError(f"component {comp!r}: joint {jname!r} is not a hinge or slide; only the "
                           "root may have a free joint")
        qpos.append(int(m.jnt_qposadr[j]))
        qvel.append(int(m.jnt_dofadr[j]))
        names.append(jname)
    actions = [i for i in range(m.nu)
               if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i).startswith(f"{comp}/")]
    # With planar root joints at their zero, the body pose is its pose at qpos0.
    return Handle(comp, body, tuple(lin_axes), tuple(lin_dofs), tuple(ang_axes), tuple(ang_dofs),
                  free, rest.xpos[body].astype(np.float32).copy(),
                  rest.xquat[body].astype(np.float32).copy(), tuple(slides), tuple(hinges),
                  np.asarray(qpos, np.int32), np.asarray(qvel, np.int32),
                  np.asarray(actions, np.int32), tuple(spec.planar_axes), tuple(names))

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
  def joint_names(self) -> dict[str, tuple[str, ...]]:
    """``{component: the MJCF names of its non-root joints}``, in the order of its
    ``joint_pos``/``joint_vel`` observations (``{"agent1": ("agent1/hip_1", ...)}``)."""
    return {name: handle.joint_names for name, handle in self._handles.items()}

  @property
  def agent_names(self) -> tuple[str, ...]:
    """The agents of a multi-agent scene, sorted (the order of reward vectors); () otherwise."""
    return self.agents.names if self.agents else ()

  @property
  def num_agents(self) -> int:
    """How many agents own rewards and actions: 1 for a single-agent scene."""
    return len(self.agents.names) if self.agents else 1

  @property
  def agent_action_indices(self) -> dict[str, np.ndarray]:
    """``{agent: indices of its actions in the full action vector}`` (multi-agent scenes)."""
    return dict(self.agents.action_indices) if self.agents else {}

  @property
  def reward_shape(self) -> tuple[int, ...]:
    """``()``, or ``(num_agents,)`` for a multi-agent scene."""
    return (len(self.agents.names),) if self.agents else ()

  @property
  def tracked_bodies(self) -> list[int]:
    """Root body ids a camera should keep in view: every agent's components in a multi-agent
    scene (the actuated ones: each is driven by exactly one agent), else the main component."""
    if not self.agents:
      return [self._handles[self.main_component].body]
    return [h.body for h in self._handles.values() if len(h.actions)]

  def _metric_keys(self) -> list[str]:
    if not self.agents:
      return [f"{kind}/{t}" for t in self.reward_terms for kind in ("reward", "score")]
    names = self.agents.names
    return ([f"{kind}/{names[i]}/{t}" for t, i in zip(self.reward_terms, self.agents.term_agent)
             for kind in ("reward", "score")] + [f"score/{a}" for a in names])

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
  def _observe(self, data: mjx.Data, contact: jax.Array) -> jax.Array:
    return jnp.concatenate([jnp.reshape(p.fn(contact if p.reads_contact else data), (-1,))
                            for p in self._pieces])

  def _contact_change(self, data: mjx.Data) -> jax.Array:
    """``[B, 6]`` velocity change (Δv, Δω) that the last physics step's contact forces gave each
    reported body: F h / m and I^-1 (r x F) h, with r from the body's centre of mass."""
    m, h = self.mj_model, float(self.mj_model.opt.timestep)
    force, idx = mjx_support.contact_force_dim(self.mjx_model, data, 3)
    if not len(idx):
      return jnp.zeros((len(self._contact_bodies), 6))
    contact = data._impl.contact
    frame, pos = contact.frame[idx], contact.pos[idx]
    world = jnp.einsum("ci,cij->cj", force[:, :3], frame)             # [C, 3]
    bodies = jnp.asarray(m.geom_bodyid, jnp.int32)[contact.geom[idx]]  # [C, 2]
    targets = jnp.asarray(self._contact_bodies, jnp.int32)
    out = []
    for b, sign in ((bodies[:, 0], -1.0), (bodies[:, 1], 1.0)):
      hit = (b[:, None] == targets[None, :]).astype(world.dtype)     # [C, B]
      f = sign * world
      lever = pos[:, None, :] - data.xipos[targets][None, :, :]       # [C, B, 3]
      torque = jnp.cross(lever, f[:, None, :])                       # [C, B, 3]
      out.append(jnp.concatenate([hit.T @ f, jnp.einsum("cb,cbi->bi", hit, torque)], -1))
    total = out[0] + out[1]                                            # [B, 6] force, torque
    mass = jnp.asarray(m.body_mass[self._contact_bodies], total.dtype)[:, None]
    inv_i = 1.0 / jnp.asarray(m.body_inertia[self._contact_bodies], total.dtype)  # principal axes
    rot = data.ximat[targets]                                          # [B, 3, 3]
    local = jnp.einsum("bji,bj->bi", rot, total[:, 3:]) * inv_i
    dw = jnp.einsum("bij,bj->bi", rot, local)
    return h * jnp.concatenate([total[:, :3] / mass, dw], -1)

  def _reward(self, data: mjx.Data, action: jax.Array):
    shape = self.reward_shape
    metrics, reward, score, done = {}, jnp.zeros(shape), jnp.zeros(shape), jnp.zeros((), bool)
    for i, term in enumerate(self._terms):
      r, s, d = term.fn(data, action)
      who = f"{self.agents.names[self.agents.term_agent[i]]}/" if self.agents else ""
      metrics[f"reward/{who}{term.name}"] = r
      metrics[f"score/{who}{term.name}"] = s
      if self.agents:
        reward = reward.at[self.agents.term_agent[i]].add(r)
        score = score.at[self.agents.term_agent[i]].add(s)
      else:
        reward, score = reward + r, score + s
      done = done | d
    if self.agents:
      metrics.update({f"score/{a}": score[i] for i, a in enumerate(self.agents.names)})
    metrics["score"] = score.sum()
    for handle, rule, offset in self._terminations:
      z = root_quantity(handle, data, "pos")[2]
      done = done | (z < rule.min_z + offset) | (z > rule.max_z + offset)
      if rule.check_flip:
        w, x, y, _ = root_quantity(handle, data, "rot")
        done = done | (1.0 - 2.0 * (x * x + y * y) < 0.0)  # z of the body's up axis is negative
    return reward, done, metrics

  def reset(self, key: jax.Array) -> State:
    """Initial state: ``init_qpos`` (each component's default pose, resting on the floor where the
    component asks for it) at rest, plus uniform noise of ``reset_noise_scale``; then, where
    ``reset_actions`` a > 0, one control step with every action drawn from U[0, a) (Brax v1's
    humanoid reset, a = 0.5), its reward and termination not counted."""
    scale = float(self.options["reset_noise_scale"])
    push = float(self.options["reset_actions"])
    qpos = jnp.asarray(self.init_qpos)
    qvel = jnp.zeros(self.mj_model.nv, jnp.float32)
    if scale > 0:
      pos_key, vel_key = jax.random.split(key)
      qpos = qpos.at[self._noise_qpos].add(
          jax.random.uniform(pos_key, (len(self._noise_qpos),), minval=-scale, maxval=scale))
      qvel = scale * jax.random.uniform(vel_key, (self.mj_model.nv,), minval=-1.0, maxval=1.0)
    data = mjx.forward(self.mjx_model, self._data0.replace(qpos=qpos, qvel=qvel))
    contact = jnp.zeros((len(self._contact_bodies), 6))
    if push > 0:
      action = push * jax.random.uniform(jax.random.fold_in(key, 1), (self.action_size,))
      data, contact = self._physics(data, action)
    metrics = {key: jnp.zeros(()) for key in self._metric_keys()}
    metrics["score"] = jnp.zeros(())
    obs = self._observe(data, contact)
    return State(data=data, obs=obs, reward=jnp.zeros(self.reward_shape), done=jnp.zeros(()),
                 metrics=metrics, info={}, contact=contact, truncation=jnp.zeros(()),
                 pre_reset_obs=obs)

  def _ctrl(self, action: jax.Array, qpos: jax.Array) -> jax.Array:
    """The motor controls for ``action``, with Brax's cut past the joint limits applied."""
    cut = self.torque_cut
    if not len(cut.actuators):
      return action
    angle = qpos[cut.qpos_adr]
    inside = (angle >= cut.low) & (angle <= cut.high)
    return action.at[cut.actuators].multiply(inside.astype(action.dtype))

  def _physics(self, data: Any, action: jax.Array) -> tuple[Any, jax.Array]:
    """``substeps`` physics steps with ``action`` held fixed, and the contact change they made."""
    observe_contact = bool(self._contact_bodies)

    def substep(_, carry):
      data, contact = carry
      data = mjx.step(self.mjx_model, data.replace(ctrl=self._ctrl(action, data.qpos)))
      if observe_contact:
        contact = contact + self._contact_change(data)
      return data, contact

    contact = jnp.zeros((len(self._contact_bodies), 6))
    return jax.lax.fori_loop(0, self.substeps, substep, (data, contact))

  def step(self, state: State, action: jax.Array) -> State:
    """Advances ``substeps`` physics steps with ``action`` (clipped to [-1, 1]) held fixed."""
    action = jnp.clip(action, -1.0, 1.0)
    data, contact = self._physics(state.data, action)
    reward, done, metrics = self._reward(data, action)
    obs = self._observe(data, contact)
    return state.replace(data=data, obs=obs, reward=reward, done=done.astype(jnp.float32),
                         metrics=metrics, contact=contact, truncation=jnp.zeros(()),
                         pre_reset_obs=obs)

  def __repr__(self) -> str:
    agents = f", agents {list(self.agents.names)}" if self.agents else ""
    return (f"Env({self.name or 'custom'}: obs {self.observation_size}, action {self.action_size}, "
            f"dt {self.dt:g}s{agents})")


class TorqueCut(NamedTuple):
  """Actuators whose control is zeroed while ``qpos[qpos_adr]`` lies outside ``[low, high]``."""

  actuators: np.ndarray
  qpos_adr: np.ndarray
  low: np.ndarray
  high: np.ndarray


def _geom_bottom(m: mujoco.MjModel, data: mujoco.MjData, geom: int) -> float:
  """The lowest world z of a sphere or capsule geom (others: its centre minus its bounding radius)."""
  z = float(data.geom_xpos[geom, 2])
  size = m.geom_size[geom]
  if m.geom_type[geom] == mujoco.mjtGeom.mjGEOM_SPHERE:
    return z - float(size[0])
  if m.geom_type[geom] == mujoco.mjtGeom.mjGEOM_CAPSULE:
    axis_z = float(data.geom_xmat[geom].reshape(3, 3)[2, 2])
    return z - abs(axis_z) * float(size[1]) - float(size[0])
  return z - float(m.geom_rbound[geom])


def _unique(pieces: list[ObsPiece]) -> list[ObsPiece]:
  """Makes layout names unique by suffixing repeats with #2, #3, ..."""
  seen: dict[str, int] = {}
  out = []
  for p in pieces:
    seen[p.name] = seen.get(p.name, 0) + 1
    out.append(p if seen[p.name] == 1 else dataclasses.replace(p, name=f"{p.name}#{seen[p.name]}"))
  return out
