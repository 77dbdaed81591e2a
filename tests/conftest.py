"""Shared fixtures. MJX compiles slowly on CPU, so compiled envs and functions are cached per session."""

from __future__ import annotations

import functools
import os

os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false")

import jax
import numpy as np
import pytest

from blx import envs


@functools.lru_cache(maxsize=None)
def make_env(name: str, **params):
  """One env object per (name, params) for the whole session."""
  return envs.create(name, **params)


@functools.lru_cache(maxsize=None)
def rollout_fn(name: str):
  """A jitted ``(keys [B], actions [T, B, A]) -> (qpos, obs, reward, done)`` for env ``name``.

  Resets with vmap, steps with vmap under ``lax.scan``, auto-resetting finished episodes so long runs
  keep exercising the physics.
  """
  env = envs.auto_reset(make_env(name))

  @jax.jit
  def rollout(keys, actions):
    state = jax.vmap(env.reset)(keys)

    def body(state, action):
      state = jax.vmap(env.step)(state, action)
      return state, (state.data.qpos, state.obs, state.reward, state.done)

    return jax.lax.scan(body, state, actions)[1]

  return rollout


@pytest.fixture
def rng():
  return np.random.default_rng(0)


@functools.lru_cache(maxsize=None)
def step_fn(name: str):
  """``(jit(reset), jit(step))`` of the cached env ``name``."""
  env = make_env(name)
  return jax.jit(env.reset), jax.jit(env.step)
