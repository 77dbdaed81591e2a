"""Videos of trained policies with MuJoCo's offscreen renderer (headless: EGL, else OSMesa)."""

from __future__ import annotations

import os

__all__ = ["ensure_headless_gl", "rollout_qpos", "render_frames", "write_video"]


def ensure_headless_gl() -> None:
  """Picks a headless OpenGL backend before mujoco's renderer loads (EGL unless one is set)."""
  os.environ.setdefault("MUJOCO_GL", "egl")
  if os.environ["MUJOCO_GL"] in ("egl", "osmesa"):
    os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])


def rollout_qpos(run, params, latents, key, *, steps: int):
  """Deterministic episodes, one per latent ``[L, Z]``: ``qpos [L, T, nq]`` (held after a
  termination), the first ``steps`` policy steps of the run's env as given (at most one episode)."""
  import jax
  import jax.numpy as jnp
  from blx import envs

  env = run.env
  steps = min(steps, envs.episode_steps(env, "render"))
  conditions = run.objective.conditions_policy
  n = latents.shape[0]

  @jax.jit
  def go(params, latents, key):
    state = jax.vmap(env.reset)(jax.random.split(key, n))
    act = lambda obs, _: run.policy(params, obs, latents if conditions else None)
    _, (qpos, done) = envs.rollout(env, act, state, steps, key,
                                   lambda state, action, nxt: (nxt.data.qpos, nxt.done))
    # After an episode ends, hold the pose of the step it ended on.
    last = (jnp.cumsum(envs.alive_before(done), axis=0) - 1).astype(jnp.int32)   # [T, L]
    qpos = jnp.take_along_axis(qpos, jnp.broadcast_to(last[..., None], qpos.shape), axis=0)
    first = state.data.qpos
    return jnp.concatenate([first[None], qpos], 0).swapaxes(0, 1)

  return go(params, latents, key)


def render_frames(mj_model, qpos, *, width: int = 320, height: int = 240):
  """RGB frames ``[T, H, W, 3]`` (uint8) of one trajectory ``qpos [T, nq]``, the camera tracking
  the first body."""
  ensure_headless_gl()
  import mujoco
  import numpy as np

  data = mujoco.MjData(mj_model)
  camera = mujoco.MjvCamera()
  camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
  camera.trackbodyid = 1 if mj_model.nbody > 1 else 0
  camera.distance = max(3.0, 2.5 * float(mj_model.stat.extent))
  camera.elevation = -35.0
  camera.azimuth = 90.0
  frames = []
  # The offscreen buffer must hold the frame (MJCF's default is 640 x 480).
  mj_model.vis.global_.offwidth = max(mj_model.vis.global_.offwidth, width)
  mj_model.vis.global_.offheight = max(mj_model.vis.global_.offheight, height)
  try:
    renderer = mujoco.Renderer(mj_model, height, width)
  except Exception as e:  # no usable OpenGL: say what to install
    raise RuntimeError(
        f"blx render: MuJoCo could not open a headless OpenGL context with MUJOCO_GL="
        f"{os.environ.get('MUJOCO_GL')} ({e}). Install EGL (apt install libegl1 libgl1-mesa-dri) "
        "or OSMesa (apt install libosmesa6) and set MUJOCO_GL=egl or osmesa") from None
  with renderer:
    for q in np.asarray(qpos):
      data.qpos[:] = q
      mujoco.mj_forward(mj_model, data)
      renderer.update_scene(data, camera)
      frames.append(renderer.render().copy())
  return np.stack(frames)


def write_video(path: str, frames, *, fps: float) -> None:
  """Writes ``frames [T, H, W, 3]`` as MP4 (H.264 through imageio-ffmpeg)."""
  import imageio.v2 as imageio
  tmp = path + ".tmp.mp4"
  imageio.mimwrite(tmp, list(frames), fps=fps, macro_block_size=1)
  os.replace(tmp, path)
