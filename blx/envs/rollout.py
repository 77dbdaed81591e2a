"""The one rollout loop of blx: training evaluation, the paper's evaluators and videos step envs
through ``rollout`` and differ only in what they record."""

from __future__ import annotations

from typing import Any, Callable

import jax
import jax.numpy as jnp

from blx.envs.env import State

__all__ = ["rollout", "alive_before"]


def rollout(env: Any, act: Callable[[jax.Array, jax.Array], jax.Array], state: State, steps: int,
            key: jax.Array, record: Callable[[State, jax.Array, State], Any]) -> tuple[State, Any]:
  """Steps the batched ``state [N]`` of ``env`` ``steps`` times: the one rollout loop of blx.

  Each step calls ``act(obs [N, O], key) -> action [N, A]`` with its own key (``key`` split into
  ``steps``), steps every env with ``env.step`` (use the env as it is wrapped: with ``episode`` but
  without ``auto_reset``, terminated envs go on stepping, as in Braxlines' evaluation) and keeps
  ``record(state, action, next_state)``.

  Returns:
    ``(final state, records)``, each leaf of ``records`` with a leading ``[steps]`` axis.
  """
  def one(state, step_key):
    action = act(state.obs, step_key)
    next_state = jax.vmap(env.step)(state, action)
    return next_state, record(state, action, next_state)

  return jax.lax.scan(one, state, jax.random.split(key, steps))


def alive_before(done: jax.Array) -> jax.Array:
  """``[T, ...]``: 1 where no episode end happened before step t (so step t still counts)."""
  ended = jnp.cumsum(done, axis=0) > 0
  return jnp.concatenate([jnp.ones_like(done[:1]), 1.0 - ended[:-1].astype(done.dtype)], axis=0)
