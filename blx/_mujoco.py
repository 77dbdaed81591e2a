"""MuJoCo, imported with its OpenGL backend off.

``import mujoco`` loads the OpenGL backend that ``MUJOCO_GL`` names, and fails outright when that
backend's library is missing (``MUJOCO_GL=osmesa`` without libOSMesa, common on clusters) or the
value is not one MuJoCo knows, although simulating needs no OpenGL. blx imports mujoco through this
module, so training, evaluation and plots run whatever ``MUJOCO_GL`` says, and only rendering
(:func:`blx.experiments.render.render_frames`) loads a backend, with an error that names the
library to install.
"""

from __future__ import annotations

import os

__all__ = ["mujoco"]


def _import_without_gl():
  saved = os.environ.get("MUJOCO_GL")
  os.environ["MUJOCO_GL"] = "disable"  # mujoco reads it once, at import
  try:
    import mujoco
  finally:
    if saved is None:
      del os.environ["MUJOCO_GL"]
    else:
      os.environ["MUJOCO_GL"] = saved
  return mujoco


mujoco = _import_without_gl()
