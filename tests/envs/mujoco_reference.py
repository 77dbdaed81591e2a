"""Plain MuJoCo (C, float64) stepping of a blx env's model, with blx's reset pose and Brax's torque cut.

The MJX env is checked against this over its first steps (``test_registered_envs``); long signature
runs (settling, random-action statistics) then use this fast path instead of MJX on CPU.
"""

from __future__ import annotations

from typing import Callable

import mujoco
import numpy as np


def ctrl_with_cut(env, action: np.ndarray, qpos: np.ndarray) -> np.ndarray:
  """``action`` with the motors of joints outside their range zeroed (the env's torque cut)."""
  ctrl = np.clip(action, -1.0, 1.0).astype(np.float64)
  cut = env.torque_cut
  if len(cut.actuators):
    angle = qpos[cut.qpos_adr]
    ctrl[cut.actuators] *= (angle >= cut.low) & (angle <= cut.high)
  return ctrl


def run(env, policy: Callable[[int, np.ndarray], np.ndarray], steps: int, *,
        model: mujoco.MjModel | None = None, stop_on_done: bool = False,
        qpos0: np.ndarray | None = None) -> dict[str, np.ndarray]:
  """Steps one episode of ``env`` (an ``Env`` or wrapper) in C MuJoCo.

  Args:
    policy: ``(t, qpos) -> action [A]``.
    steps: env steps (each ``env.substeps`` physics steps).
    model: a modified copy of ``env.mj_model`` (e.g. zero gravity); default the env's.
    stop_on_done: stop at the first step whose torso height leaves the termination range.
    qpos0: the initial pose (default: the env's reset pose).

  Returns:
    ``qpos [T, nq]`` and ``qvel [T, nv]`` after each env step.
  """
  base = env.unwrapped if hasattr(env, "unwrapped") else env
  m = model if model is not None else base.mj_model
  d = mujoco.MjData(m)
  d.qpos[:] = base.init_qpos if qpos0 is None else qpos0
  mujoco.mj_forward(m, d)
  qpos, qvel = [], []
  for t in range(steps):
    action = policy(t, d.qpos.copy())
    for _ in range(base.substeps):
      d.ctrl[:] = ctrl_with_cut(base, action, d.qpos)
      mujoco.mj_step(m, d)
    qpos.append(d.qpos.copy())
    qvel.append(d.qvel.copy())
    if stop_on_done and not 0.2 <= d.qpos[2] <= 1.0:
      break
  return dict(qpos=np.asarray(qpos), qvel=np.asarray(qvel))
