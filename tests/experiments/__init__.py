"""Tests of ``blx.experiments`` and of the scripts in ``benchmarks/``."""

import importlib.util
import pathlib
import sys

import jax.numpy as jnp

BENCHMARKS = pathlib.Path(__file__).resolve().parents[2] / "benchmarks"


def load_benchmark(name: str):
  """Imports ``benchmarks/NAME.py`` (not a package) as the module ``NAME``.

  It is registered in ``sys.modules`` (dataclasses look their module up there), and
  ``benchmarks/`` goes on ``sys.path`` first, since some scripts import their neighbours
  (``common``, ``paper_tables``) by name."""
  if name in sys.modules and getattr(sys.modules[name], "__file__", None) == str(
      BENCHMARKS / f"{name}.py"):
    return sys.modules[name]
  if str(BENCHMARKS) not in sys.path:
    sys.path.insert(0, str(BENCHMARKS))
  spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
  module = importlib.util.module_from_spec(spec)
  sys.modules[name] = module
  try:
    spec.loader.exec_module(module)
  except BaseException:
    del sys.modules[name]
    raise
  return module


class EchoEnv:
  """A one-number env for the analyses' rollout tests: its observation is the last action, so a
  policy's episodes read back exactly what it chose (wrap it in ``blx.envs.episode``)."""

  observation_size, action_size = 1, 1

  def reset(self, key):
    from blx.envs.env import State
    return State(data=jnp.zeros(()), obs=jnp.zeros(1), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    return state.replace(data=state.data + 1.0, obs=action)
