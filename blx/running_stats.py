"""Running mean and variance of observations (a pytree), and the clipped normalisation that uses it.

Shared by PPO's observation normaliser and the objectives' ``normalize_obs`` option.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

__all__ = ["RunningStats", "init_stats", "update_stats", "normalize"]


@struct.dataclass
class RunningStats:
  """Running mean and variance of observations (parallel Welford), a pytree."""

  count: jax.Array
  mean: jax.Array
  m2: jax.Array


def init_stats(size: int) -> RunningStats:
  return RunningStats(jnp.zeros(()), jnp.zeros(size), jnp.zeros(size))


def update_stats(stats: RunningStats, batch: jax.Array) -> RunningStats:
  """Merges a batch ``[N, O]`` into the statistics (Chan et al.'s parallel update)."""
  n = jnp.asarray(batch.shape[0], jnp.float32)
  mean_b = batch.mean(0)
  m2_b = ((batch - mean_b) ** 2).sum(0)
  total = stats.count + n
  delta = mean_b - stats.mean
  mean = stats.mean + delta * n / total
  m2 = stats.m2 + m2_b + delta**2 * stats.count * n / total
  return RunningStats(total, mean, m2)


def normalize(stats: RunningStats, x: jax.Array, enabled: bool = True) -> jax.Array:
  """(x - mean) / std clipped to [-5, 5]; the variance is clipped to [1e-6, 1e6]."""
  if not enabled:
    return x
  var = jnp.clip(stats.m2 / jnp.maximum(stats.count, 1.0), 1e-6, 1e6)
  return jnp.clip((x - stats.mean) / jnp.sqrt(var), -5.0, 5.0)
