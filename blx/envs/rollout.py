"""The one rollout loop of blx: training evaluation, the paper's evaluators and videos step envs
through ``rollout`` and differ only in what they record; ``rollout_together`` steps several
``Episodes`` batches of one env as one batch."""

from __future__ import annotations

from typing import Any, Callable, NamedTuple, Sequence

import jax
import jax.numpy as jnp

from blx.envs.env import State

__all__ = ["rollout", "alive_before", "Episodes", "rollout_together"]


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
  return _loop(env, act, state, jax.random.split(key, steps), record)


def _loop(env, act, state, step_keys, record):
  """The loop itself: one step per leading entry of ``step_keys``, given to ``act``."""
  def one(state, step_key):
    action = act(state.obs, step_key)
    next_state = jax.vmap(env.step)(state, action)
    return next_state, record(state, action, next_state)

  return jax.lax.scan(one, state, step_keys)


class Episodes(NamedTuple):
  """A batch of whole episodes to run, as an evaluator hands it over: ``rollout`` on ``env`` from
  ``state [N]`` for ``steps`` steps with ``act``, per-step keys from ``key``, keeping ``record``."""

  env: Any
  state: State
  act: Callable[[jax.Array, jax.Array], jax.Array]
  record: Callable[[State, jax.Array, State], Any]
  key: jax.Array
  steps: int


def rollout_together(batches: Sequence[Episodes]) -> list[Any]:
  """Every batch's records (leaves ``[steps, N_i, ...]``, in order), from one loop that steps all
  the batches' envs as one batch.

  An evaluation episode is a long chain of small steps, so on a GPU it costs the latency of its
  steps, nearly whatever the number of envs; run together, several evaluations cost about one.
  Each batch's ``act`` sees its own envs' observations and gets the per-step keys its own ``key``
  gives, so a batch's records are those of ``rollout`` on it alone, up to the rounding of batched
  arithmetic. The batches must share one env (the same object) and one number of steps.
  """
  batches = list(batches)
  if not batches:
    raise ValueError("rollout_together: no batches of episodes given")
  env, steps = batches[0].env, batches[0].steps
  for i, b in enumerate(batches[1:], 1):
    if b.env is not env or b.steps != steps:
      raise ValueError(f"rollout_together: batch {i} runs {b.steps} steps on {b.env!r}, batch 0 "
                       f"{steps} on {env!r}; batches run together share one env object and one "
                       "number of steps (run the others with rollout)")
  sizes = [jax.tree.leaves(b.state)[0].shape[0] for b in batches]
  bounds = [sum(sizes[:i]) for i in range(len(sizes) + 1)]

  def part(tree, i):
    return jax.tree.map(lambda x: x[bounds[i]:bounds[i + 1]], tree)

  def act(obs, step_keys):
    return jnp.concatenate([b.act(part(obs, i), step_keys[i]) for i, b in enumerate(batches)])

  def record(state, action, next_state):
    return tuple(b.record(part(state, i), part(action, i), part(next_state, i))
                 for i, b in enumerate(batches))

  state = jax.tree.map(lambda *x: jnp.concatenate(x), *[b.state for b in batches])
  keys = jnp.stack([jax.random.split(b.key, steps) for b in batches], axis=1)  # [T, P, ...]
  return list(_loop(env, act, state, keys, record)[1])


def alive_before(done: jax.Array) -> jax.Array:
  """``[T, ...]``: 1 where no episode end happened before step t (so step t still counts)."""
  ended = jnp.cumsum(done, axis=0) > 0
  return jnp.concatenate([jnp.ones_like(done[:1]), 1.0 - ended[:-1].astype(done.dtype)], axis=0)
