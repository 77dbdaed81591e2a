"""Shared fixtures. MJX compiles slowly on CPU, so compiled envs and functions are cached per session."""

from __future__ import annotations

import atexit
import functools
import os
import shutil
import subprocess
import sys
import tempfile

# XLA's flags for the test run, unless XLA_FLAGS is set already (pytest-xdist's workers and the CLI
# subprocesses the tests start inherit the run's). Most of the suite's time is XLA compiling MJX
# programs on the CPU.
# - `NO_FUSION_EMITTERS`: XLA's CPU backend emits each fusion through its newer MLIR emitters by
#   default; with them off it uses its older loop emitters, which compile a training program of the
#   point in about 40 % less time and a 1000-step rollout of sumo in a third of it, and run it no
#   slower (RESULTS, session 83). The run-bound tests (below) run without it, at XLA's defaults:
#   under it GAIL's median seed on the point ended at an energy distance of 3.99, past its test's
#   3.35.
# - `FAST_COMPILE`: LLVM's optimisation off. Compiles take less time and the few long-running
#   learning tests run 15-35 % longer (RESULTS, session 37), so those (``run_bound``, below) run at
#   XLA's default optimisation (session 82), as does the env rollout of ``rollout_fn`` (session 83).
#   Its second flag is a no-op (with a warning) in jax 0.10, where the older runtime is gone.
# The flags change how XLA compiles a program, not the operations it computes, but the floats can
# differ in their last bits; a learning test of one seed can amplify that into another outcome
# (session 39: GAIL on the point, on an AVX-512 CPU), so the learning tests found to hang on one
# seed (DIAYN and GAIL on the point) ask their claim of the median of three seeds. A flag this jax's
# XLA lacks (an unknown flag aborts the process) is left out, saying so.
SERIAL = "--xla_cpu_multi_thread_eigen=false"
NO_FUSION_EMITTERS = "--xla_cpu_use_fusion_emitters=false"
FAST_COMPILE = "--xla_backend_optimization_level=0 --xla_cpu_use_thunk_runtime=false"


def _starts_with(flags: str) -> bool:
  """Whether jax starts on the CPU under ``XLA_FLAGS=flags``."""
  try:
    return subprocess.run(
        [sys.executable, "-c", "import jax; jax.numpy.zeros(1).block_until_ready()"],
        env={**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu"}, capture_output=True,
        timeout=300).returncode == 0
  except subprocess.TimeoutExpired:
    return False


def _xla_flags() -> str:
  """``SERIAL`` with ``NO_FUSION_EMITTERS`` and ``FAST_COMPILE``, each where this jax's XLA accepts
  it."""
  extras = (NO_FUSION_EMITTERS, FAST_COMPILE)
  if _starts_with(" ".join((SERIAL, *extras))):
    return " ".join((SERIAL, *extras))
  flags = SERIAL
  for extra in extras:
    if _starts_with(f"{flags} {extra}"):
      flags = f"{flags} {extra}"
    else:
      print(f"tests/conftest.py: this jax's XLA did not start with {extra!r}; the tests run "
            "without it (slower compiles, the same tests)", file=sys.stderr)
  return flags


if "XLA_FLAGS" not in os.environ:
  os.environ["XLA_FLAGS"] = _xla_flags()

import jax
import numpy as np
import pytest

# One compilation cache for the test run (unless BLX_COMPILATION_CACHE=off), shared by pytest-xdist's
# workers and the CLI subprocesses the tests start (they inherit the variable): programs compiled
# again (the same env or chunk in another test or process) load from it. The process that made it
# removes it at exit.
if os.environ.get("BLX_COMPILATION_CACHE", "").lower() != "off":
  _CACHE = os.environ.get("BLX_TEST_JAX_CACHE")
  if not _CACHE:
    _CACHE = os.environ["BLX_TEST_JAX_CACHE"] = tempfile.mkdtemp(prefix="blx-test-jax-cache-")
    atexit.register(shutil.rmtree, _CACHE, True)
  os.environ["BLX_COMPILATION_CACHE"] = _CACHE
  jax.config.update("jax_compilation_cache_dir", _CACHE)

from blx import envs


# A program that runs long (a 1000-step rollout of an MJX env) is compiled at XLA's default
# optimisation (level 3) where the run's flags have ``FAST_COMPILE``: on this suite's CPUs a
# 1000-step rollout of sumo (with ``NO_FUSION_EMITTERS``) compiles in 4.3 s and runs in 2.4 s at the
# default, against 2.4 s and 12.1 s at level 0 (RESULTS, session 83). ``None`` where the flags leave
# it at the default already.
RUN_BOUND_COMPILE = ({"xla_backend_optimization_level": 3}
                     if FAST_COMPILE in os.environ.get("XLA_FLAGS", "") else None)


@functools.lru_cache(maxsize=None)
def make_env(name: str, **params):
  """One env object per (name, params) for the whole session."""
  return envs.create(name, **params)


@functools.lru_cache(maxsize=None)
def rollout_fn(name: str):
  """A jitted ``(keys [B], actions [T, B, A]) -> (qpos, obs, reward, done)`` for env ``name``.

  Resets with vmap, steps with vmap under ``lax.scan``, auto-resetting finished episodes so long runs
  keep exercising the physics. It runs long, so it compiles under ``RUN_BOUND_COMPILE``.
  """
  env = envs.auto_reset(make_env(name))

  @functools.partial(jax.jit, compiler_options=RUN_BOUND_COMPILE)
  def rollout(keys, actions):
    state = jax.vmap(env.reset)(keys)

    def body(state, action):
      state = jax.vmap(env.step)(state, action)
      return state, (state.data.qpos, state.obs, state.reward, state.done)

    return jax.lax.scan(body, state, actions)[1]

  return rollout


# Tests marked ``run_bound`` spend their time running programs, not compiling them (a few learning
# tests that train for 100-600 k env steps). ``FAST_COMPILE`` slows such a run by a third or more,
# so each runs in a process of its own under the run's XLA flags less ``FAST_COMPILE`` and
# ``NO_FUSION_EMITTERS`` (XLA's defaults, under which their verdicts were set), sharing the run's
# compilation cache; its output comes back where it fails. Tests marked ``xla_defaults`` run the
# same way for another reason: they claim bitwise-equal results from differently built programs
# (a chunk whole and in segments), which holds under XLA's defaults, as users run, and not always
# under ``NO_FUSION_EMITTERS`` (last bits, session 83).
RUN_BOUND_CHILD = "BLX_TEST_RUN_BOUND_CHILD"


def pytest_configure(config):
  config.addinivalue_line("markers", "xla_defaults: runs in a process of its own at XLA's defaults "
                          "(tests/conftest.py)")
  config.addinivalue_line("markers", "run_bound: runs in a process of its own at XLA's defaults, "
                          "where it runs faster (tests/conftest.py)")


def pytest_pyfunc_call(pyfuncitem):
  marked = any(pyfuncitem.get_closest_marker(m) for m in ("run_bound", "xla_defaults"))
  if not marked or os.environ.get(RUN_BOUND_CHILD):
    return None
  flags = os.environ.get("XLA_FLAGS", "").replace(FAST_COMPILE, "").replace(NO_FUSION_EMITTERS, "")
  flags = " ".join(flags.split()) or SERIAL
  env = {**os.environ, RUN_BOUND_CHILD: "1", "XLA_FLAGS": flags}
  child = subprocess.run(
      [sys.executable, "-m", "pytest", "-q", "-o", "addopts=", "-p", "no:cacheprovider",
       "-p", "no:xdist", pyfuncitem.nodeid], cwd=str(pyfuncitem.config.rootpath), env=env,
      capture_output=True, text=True)
  if child.returncode != 0:
    pytest.fail(f"{pyfuncitem.nodeid}, run in a process of its own under XLA_FLAGS={flags!r}, "
                f"exited with {child.returncode}:\n{(child.stdout + child.stderr)[-12_000:]}",
                pytrace=False)
  if "1 passed" not in child.stdout:
    pytest.skip(f"in a process of its own: {child.stdout.strip().splitlines()[-1:]}")
  return True


@pytest.fixture
def rng():
  return np.random.default_rng(0)


@functools.lru_cache(maxsize=None)
def step_fn(name: str):
  """``(jit(reset), jit(step))`` of the cached env ``name``."""
  env = make_env(name)
  return jax.jit(env.reset), jax.jit(env.step)
