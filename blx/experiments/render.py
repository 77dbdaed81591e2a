"""Videos of trained policies with MuJoCo's offscreen renderer (headless: EGL, else OSMesa)."""

from __future__ import annotations

import os

__all__ = ["GLError", "ensure_headless_gl", "load_gl_backend", "rollout_qpos", "render_frames",
           "colour_agents", "label_frames", "write_video"]

# What each MUJOCO_GL backend needs on the machine.
GL_NEEDS = {
    "egl": "EGL: libEGL with a driver, NVIDIA's own or Mesa's (apt install libegl1 libegl-mesa0 "
           "libgl1-mesa-dri)",
    "osmesa": "OSMesa, software rendering (apt install libosmesa6; dnf install mesa-libOSMesa)",
    "glfw": "GLFW and a display (apt install libglfw3, and DISPLAY set); without a display use "
            "MUJOCO_GL=egl or osmesa",
    "glx": "GLX and a display (apt install libgl1, and DISPLAY set); without a display use "
           "MUJOCO_GL=egl or osmesa",
}


class GLError(RuntimeError):
  """No usable OpenGL backend for rendering; the message names what to install."""


def ensure_headless_gl() -> None:
  """Picks a headless OpenGL backend before mujoco's renderer loads (EGL unless one is set)."""
  os.environ.setdefault("MUJOCO_GL", "egl")
  if os.environ["MUJOCO_GL"] in ("egl", "osmesa"):
    os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])


def _gl_error(backend: str, cause: BaseException | str) -> GLError:
  return GLError(f"rendering needs an OpenGL backend, and MUJOCO_GL={backend} could not be loaded "
                 f"({cause}). It needs {GL_NEEDS[backend]}. Only rendering needs OpenGL: train, "
                 "eval and sweep run without it")


def load_gl_backend() -> str:
  """Loads the OpenGL backend that ``MUJOCO_GL`` names (EGL unless set) into mujoco's renderer and
  returns its name.

  blx imports mujoco with its backend off (``blx._mujoco``), so this is the one place a backend
  loads. Raises :class:`GLError` naming the library to install for that backend, or the valid
  values of ``MUJOCO_GL``.
  """
  import importlib

  from blx._mujoco import mujoco  # noqa: F401  (mujoco itself, without GL)
  ensure_headless_gl()
  backend = os.environ["MUJOCO_GL"].lower().strip()
  if backend not in GL_NEEDS:
    raise GLError(f"rendering needs an OpenGL backend: MUJOCO_GL={os.environ['MUJOCO_GL']!r} is "
                  f"not one of {sorted(GL_NEEDS)} (unset, it is egl)")
  try:
    from mujoco.rendering.classic import gl_context
  except ImportError:  # mujoco before 3.4 kept it at the top level
    from mujoco import gl_context
  try:
    importlib.reload(gl_context)  # reads MUJOCO_GL now
    context = getattr(gl_context, "GLContext", None)
  except Exception as e:  # pyopengl fails with AttributeError, ctypes with OSError, ...
    raise _gl_error(backend, f"{type(e).__name__}: {e}") from None
  if context is None or context.__name__ == "_MissingGLContext":
    raise _gl_error(backend, "mujoco found no GL context class for it")
  return backend


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


def render_frames(mj_model, qpos, *, width: int = 320, height: int = 240,
                  track: list[int] | None = None):
  """RGB frames ``[T, H, W, 3]`` (uint8) of one trajectory ``qpos [T, nq]``, the camera tracking
  the first body, or, with ``track`` (body ids, e.g. every agent's root: ``Env.tracked_bodies``),
  looking at their centre from far enough to keep them all in view. Raises :class:`GLError` when
  no OpenGL backend can be loaded."""
  backend = load_gl_backend()
  import numpy as np

  from blx._mujoco import mujoco

  data = mujoco.MjData(mj_model)
  camera = mujoco.MjvCamera()
  camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
  camera.trackbodyid = 1 if mj_model.nbody > 1 else 0
  camera.distance = base = max(3.0, 2.5 * float(mj_model.stat.extent))
  if track is not None and len(track) > 1:
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    track = np.asarray(track, np.int64)
  else:
    track = None
  camera.elevation = -35.0
  camera.azimuth = 90.0
  frames = []
  # The offscreen buffer must hold the frame (MJCF's default is 640 x 480).
  mj_model.vis.global_.offwidth = max(mj_model.vis.global_.offwidth, width)
  mj_model.vis.global_.offheight = max(mj_model.vis.global_.offheight, height)
  try:
    renderer = mujoco.Renderer(mj_model, height, width)
  except Exception as e:  # the backend loaded but opens no context (no device, no display)
    raise _gl_error(backend, f"{type(e).__name__}: {e}") from None
  with renderer:
    for q in np.asarray(qpos):
      data.qpos[:] = q
      mujoco.mj_forward(mj_model, data)
      if track is not None:
        points = data.xpos[track]
        centre = points.mean(0)
        camera.lookat[:] = centre
        spread = float(np.linalg.norm(points - centre, axis=1).max())
        camera.distance = max(base, 2.0 * spread + 2.0)
      renderer.update_scene(data, camera)
      frames.append(renderer.render().copy())
  return np.stack(frames)


# One colour per agent of a multi-agent scene (RGBA), and the word a label uses for it.
AGENT_COLOURS = (("blue", (0.25, 0.50, 0.90, 1.0)), ("orange", (0.95, 0.55, 0.15, 1.0)),
                 ("green", (0.30, 0.70, 0.30, 1.0)), ("red", (0.85, 0.25, 0.25, 1.0)),
                 ("purple", (0.60, 0.35, 0.80, 1.0)), ("brown", (0.55, 0.35, 0.20, 1.0)),
                 ("pink", (0.95, 0.50, 0.75, 1.0)), ("grey", (0.50, 0.50, 0.50, 1.0)))


def colour_agents(mj_model, agent_names):
  """A copy of ``mj_model`` in which every geom of agent i (the bodies named ``<agent>/...``) has
  colour i of :data:`AGENT_COLOURS` (cycling past eight agents), so that a video tells the agents
  apart; and the legend, e.g. ``"agent0 blue, agent1 orange"``. The scene's other geoms keep
  theirs. The model the env steps with is not touched."""
  import copy

  model = copy.deepcopy(mj_model)
  legend = []
  for i, agent in enumerate(agent_names):
    word, rgba = AGENT_COLOURS[i % len(AGENT_COLOURS)]
    legend.append(f"{agent} {word}")
    for g in range(model.ngeom):
      if model.body(int(model.geom_bodyid[g])).name.startswith(agent + "/"):
        model.geom_rgba[g] = rgba
        model.geom_matid[g] = -1  # a material's colour would win over the geom's
  return model, ", ".join(legend)


def label_frames(frames, text: str):
  """``frames [T, H, W, 3]`` with ``text`` in a dark band across the top (e.g. "skill 3"), one line
  of the band per line of ``text``, so a video of several episodes says which one is playing.
  Pillow (matplotlib's own dependency) draws it."""
  import numpy as np
  from PIL import Image, ImageDraw, ImageFont

  frames = np.asarray(frames)
  line = max(12, frames.shape[1] // 12)
  lines = text.split("\n")
  band = min(line * len(lines), frames.shape[1])
  try:  # a scalable font where Pillow has FreeType, else its small bitmap font
    font = ImageFont.load_default(size=line - 4)
  except (TypeError, OSError, ImportError):
    font = ImageFont.load_default()
  out = np.array(frames, copy=True)
  out[:, :band] = (out[:, :band] * 0.35).astype(out.dtype)  # darken, keep the scene visible
  stamp = Image.fromarray(np.zeros((band, frames.shape[2], 3), np.uint8))
  draw = ImageDraw.Draw(stamp)
  for i, words in enumerate(lines):
    draw.text((4, 1 + i * line), words, fill=(255, 255, 255), font=font)
  ink = np.asarray(stamp)
  out[:, :band] = np.maximum(out[:, :band], ink[None])
  return out


def write_video(path: str, frames, *, fps: float) -> None:
  """Writes ``frames [T, H, W, 3]`` as MP4 (H.264 through imageio-ffmpeg)."""
  import imageio.v2 as imageio
  tmp = path + ".tmp.mp4"
  imageio.mimwrite(tmp, list(frames), fps=fps, macro_block_size=1)
  os.replace(tmp, path)
