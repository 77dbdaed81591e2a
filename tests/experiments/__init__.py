"""Tests of ``blx.experiments`` and of the scripts in ``benchmarks/``."""

import importlib.util
import pathlib
import sys

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
