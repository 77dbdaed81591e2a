"""Wrappers: functions of an ``Env`` returning an ``Env``-like object with new ``reset``/``step``.

Every other attribute (``obs_layout``, ``obs_indices``, ``mj_model``, ...) is read through to the
wrapped env, and ``unwrapped`` gives the bare ``Env``.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from blx.envs.env import State

__all__ = ["Wrapper", "action_repeat", "episode", "auto_reset", "unwrap", "episode_steps",
           "resets_itself"]

MAX_STEPS = 2**31 - 1  # step counters are 32-bit on the device


class Wrapper:
  """Base wrapper: delegates everything to ``env``."""

  def __init__(self, env: Any):
    self.env = env

  def __getattr__(self, name: str) -> Any:
    if name == "env":
      raise AttributeError(name)
    return getattr(self.env, name)

  @property
  def unwrapped(self):
    return unwrap(self.env)

  def reset(self, key: jax.Array) -> State:
    return self.env.reset(key)

  def step(self, state: State, action: jax.Array) -> State:
    return self.env.step(state, action)

  def __repr__(self) -> str:
    return f"{type(self).__name__}({self.env!r})"


def unwrap(env: Any):
  """The bare ``Env`` under any number of wrappers."""
  while isinstance(env, Wrapper):
    env = env.env
  return env


class _ActionRepeat(Wrapper):
  def __init__(self, env, repeat: int):
    super().__init__(env)
    self.action_repeat = repeat

  def step(self, state, action):
    def one(carry, _):
      s, reward, done = carry
      s = self.env.step(s, action)
      return (s, reward + s.reward, jnp.maximum(done, s.done)), s.metrics

    (state, reward, done), metrics = jax.lax.scan(
        one, (state, jnp.zeros(()), jnp.zeros(())), None, length=self.action_repeat)
    summed = {k: v.sum(0) for k, v in metrics.items()}
    return state.replace(reward=reward, done=done, metrics=summed)


def action_repeat(env, repeat: int):
  """Repeats each action ``repeat`` times; rewards and reward metrics are summed, done is any."""
  if not isinstance(repeat, int) or isinstance(repeat, bool) or not 1 <= repeat <= MAX_STEPS:
    raise ValueError(f"action_repeat must be an int in 1..2**31 - 1, got {repeat!r}")
  return env if repeat == 1 else _ActionRepeat(env, repeat)


class _Episode(Wrapper):
  def __init__(self, env, length: int):
    super().__init__(env)
    self.episode_length = length
    self._increment = getattr(env, "action_repeat", 1)  # counts steps of the unrepeated env

  def reset(self, key):
    state = self.env.reset(key)
    return state.replace(truncation=jnp.zeros(()), info={**state.info, "steps": jnp.zeros(())})

  def step(self, state, action):
    state = self.env.step(state, action)
    steps = state.info["steps"] + self._increment
    limit = steps >= self.episode_length
    # Truncation (time limit, not termination) tells the learner to bootstrap from the value.
    truncation = jnp.where(limit, 1.0 - state.done, 0.0)
    done = jnp.where(limit, 1.0, state.done)
    return state.replace(done=done, truncation=truncation, info={**state.info, "steps": steps})


def episode_steps(env, who: str = "episode_steps") -> int:
  """Policy steps in one whole episode of ``env``: its ``episode_length`` over its
  ``action_repeat``, rounded up. The env must carry a time limit (``blx.envs.create`` gives one by
  default) and must not reset itself, so that an episode is seen to end."""
  length = getattr(env, "episode_length", None)
  if length is None:
    raise ValueError(f"{who}: the env has no time limit, so an episode never ends; create it with "
                     "one, e.g. blx.envs.create(name, episode_length=1000)")
  if resets_itself(env):
    raise ValueError(f"{who}: the env already resets itself (auto_reset); pass it without: "
                     "training adds auto-reset and evaluation runs whole episodes")
  return -(-length // getattr(env, "action_repeat", 1))


def episode(env, length: int):
  """Ends episodes after ``length`` steps (of the unrepeated env), setting ``State.truncation`` = 1
  when time ran out."""
  if not isinstance(length, int) or isinstance(length, bool) or not 1 <= length <= MAX_STEPS:
    raise ValueError(f"episode_length must be an int in 1..2**31 - 1 (or None: no time limit), "
                     f"got {length!r}")
  return _Episode(env, length)


class _AutoReset(Wrapper):
  def reset(self, key):
    state = self.env.reset(key)
    return state.replace(info={**state.info, "first_data": state.data, "first_obs": state.obs})

  def step(self, state, action):
    info = dict(state.info)
    if "steps" in info:
      info["steps"] = jnp.where(state.done > 0, 0.0, info["steps"])
    state = self.env.step(state.replace(done=jnp.zeros_like(state.done), info=info), action)
    reset = lambda first, now: jnp.where(state.done > 0, first, now)
    data = jax.tree.map(reset, state.info["first_data"], state.data)
    obs = reset(state.info["first_obs"], state.obs)
    return state.replace(data=data, obs=obs, pre_reset_obs=state.obs)


def resets_itself(env) -> bool:
  """Whether ``auto_reset`` wraps ``env`` anywhere."""
  while isinstance(env, Wrapper):
    if isinstance(env, _AutoReset):
      return True
    env = env.env
  return False


def auto_reset(env):
  """Returns to the first state of the episode when it ends.

  The terminal step keeps its reward and done; ``obs`` becomes the reset observation and
  ``State.pre_reset_obs`` keeps the observation the step really reached (for bootstrapping).
  """
  return _AutoReset(env)
