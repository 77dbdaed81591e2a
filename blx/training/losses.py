"""PPO's pieces: generalised advantage estimation and the clipped surrogate."""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp

__all__ = ["gae", "sequence_advantages", "clipped_surrogate"]


def gae(reward_t: jax.Array, value_t: jax.Array, next_value_t: jax.Array,
        termination_t: jax.Array, done_t: jax.Array, *, discount: float,
        lam: float, known_t: jax.Array | None = None) -> tuple[jax.Array, jax.Array]:
  """Generalised advantage estimation over one sequence ``[T]`` (Schulman et al., 2016).

      delta_t = r_t + discount * (1 - term_t) * V(s'_t) - V(s_t)
      A_t     = delta_t + discount * lam * (1 - done_t) * A_{t+1},   A_T = 0

  ``next_value_t`` is V at the true next state s'_t (before any auto-reset), so a time-limit
  truncation (done but not terminated) bootstraps from V(s'_t); a termination does not. The
  recursion stops at every episode end.

  ``known_t`` (optional, 1 or 0) marks where ``next_value_t`` really is V(s'_t). Where it is 0 (a
  truncation inside a sequence whose next entry is already the reset state) delta_t is set to 0,
  so A_t = 0 and the value target is V(s_t) itself: the step teaches nothing, as in Brax.

  Returns:
    ``(advantages [T], value targets [T] = A_t + V(s_t))``.
  """
  chex.assert_rank([reward_t, value_t, next_value_t, termination_t, done_t], 1)
  chex.assert_equal_shape([reward_t, value_t, next_value_t, termination_t, done_t])
  delta = reward_t + discount * (1.0 - termination_t) * next_value_t - value_t
  if known_t is not None:
    chex.assert_equal_shape([known_t, delta])
    delta = delta * known_t

  def backward(next_advantage, inputs):
    delta_t, done = inputs
    advantage = delta_t + discount * lam * (1.0 - done) * next_advantage
    return advantage, advantage

  _, advantages = jax.lax.scan(backward, jnp.zeros((), delta.dtype), (delta, done_t), reverse=True)
  return advantages, advantages + value_t


def sequence_advantages(reward: jax.Array, values: jax.Array, done: jax.Array,
                        truncation: jax.Array, *, discount: float,
                        lam: float) -> tuple[jax.Array, jax.Array]:
  """GAE for rollout sequences ``[B, T]`` of auto-reset envs, from one value pass ``[B, T + 1]``.

  ``values[:, t]`` is V(s_t) for t < T and ``values[:, T]`` is V(s'_{T-1}), the true state after the
  last step. Inside a sequence V(s'_t) = V(s_{t+1}), except after an episode end, where s_{t+1} is
  already the next episode's first state:

  * a termination (done, not truncated) does not bootstrap, so that value is never used;
  * a truncation (time limit) should bootstrap from V(s'_t), which is known only at the last step
    (``values[:, T]``); inside the sequence its delta is set to 0 (``known_t`` of ``gae``).

  Returns:
    ``(advantages [B, T], value targets [B, T])``.
  """
  chex.assert_rank([reward, values, done, truncation], 2)
  chex.assert_equal_shape([reward, done, truncation])
  chex.assert_axis_dimension(values, 1, reward.shape[1] + 1)
  value, next_value = values[:, :-1], values[:, 1:]
  termination = done * (1.0 - truncation)
  inside = jnp.arange(reward.shape[1]) < reward.shape[1] - 1
  known = 1.0 - truncation * inside
  return jax.vmap(lambda r, v, nv, t, d, k: gae(r, v, nv, t, d, discount=discount, lam=lam,
                                                known_t=k))(
      reward, value, next_value, termination, done, known)


def clipped_surrogate(log_prob: jax.Array, old_log_prob: jax.Array, advantage: jax.Array, *,
                      epsilon: float) -> jax.Array:
  """PPO's clipped objective as a loss (Schulman et al., 2017), averaged over the batch:

      -mean(min(rho * A, clip(rho, 1 - eps, 1 + eps) * A)),  rho = exp(log pi - log pi_old)
  """
  chex.assert_equal_shape([log_prob, old_log_prob, advantage])
  ratio = jnp.exp(log_prob - old_log_prob)
  clipped = jnp.clip(ratio, 1.0 - epsilon, 1.0 + epsilon)
  return -jnp.mean(jnp.minimum(ratio * advantage, clipped * advantage))
