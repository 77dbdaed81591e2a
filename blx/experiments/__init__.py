"""blx.experiments — the front door: the ``blx`` command, run directories, sweeps, plots, videos.

Imports are lazy so that ``blx render`` can choose MuJoCo's OpenGL backend before mujoco loads.
"""

import importlib

_EXPORTS = {
    "Run": "runs", "RunError": "runs", "RunSpec": "runs", "load_run": "runs",
    "train_run": "runs", "write_eval": "runs", "expand": "sweep", "load_spec": "sweep",
    "run_sweep": "sweep",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
  if name in _EXPORTS:
    return getattr(importlib.import_module(f"blx.experiments.{_EXPORTS[name]}"), name)
  raise AttributeError(f"module 'blx.experiments' has no attribute {name!r}")
