"""Policy and value networks, the tanh-squashed Gaussian, and the running observation normaliser."""

from __future__ import annotations

from typing import Sequence

import distrax
import flax.linen as nn
import jax
import jax.numpy as jnp

# The running normaliser is shared with the objectives' ``normalize_obs``.
from blx.running_stats import RunningStats, init_stats, normalize, update_stats

__all__ = ["MLP", "sample_raw_action", "log_prob_raw", "entropy", "deterministic_action",
           "RunningStats", "init_stats", "update_stats", "normalize"]


class MLP(nn.Module):
  """Dense layers with swish between them (lecun-uniform kernels, as Brax)."""

  layer_sizes: Sequence[int]

  @nn.compact
  def __call__(self, x: jax.Array) -> jax.Array:
    for i, size in enumerate(self.layer_sizes):
      x = nn.Dense(size, kernel_init=nn.initializers.lecun_uniform())(x)
      if i < len(self.layer_sizes) - 1:
        x = nn.swish(x)
    return x


# A policy outputs ``logits [..., 2A]``: the Gaussian's mean and a pre-softplus scale. Actions are
# a = tanh(u), u ~ N(mean, softplus(scale) + 0.001). Log-probabilities are taken on the raw u, where
# they are exact and stable; the tanh correction log|da/du| cancels in PPO's ratio.

def _gaussian(logits: jax.Array) -> distrax.Normal:
  loc, scale = jnp.split(logits, 2, axis=-1)
  return distrax.Normal(loc, jax.nn.softplus(scale) + 0.001)


def sample_raw_action(logits: jax.Array, key: jax.Array) -> jax.Array:
  """u ~ N(mean, std), the pre-tanh action ``[..., A]``."""
  return _gaussian(logits).sample(seed=key)


def log_prob_raw(logits: jax.Array, raw_action: jax.Array) -> jax.Array:
  """log N(u; mean, std) summed over action dimensions ``[...]``."""
  return _gaussian(logits).log_prob(raw_action).sum(-1)


def entropy(logits: jax.Array, key: jax.Array) -> jax.Array:
  """Entropy of tanh(u): H[N] + E[log|d tanh(u)/du|], the expectation from one sample (as Brax)."""
  dist = _gaussian(logits)
  sample = dist.sample(seed=key)
  return (dist.entropy() + distrax.Tanh().forward_log_det_jacobian(sample)).sum(-1)


def deterministic_action(logits: jax.Array) -> jax.Array:
  """tanh(mean): the mode of the squashed policy, used for evaluation."""
  return jnp.tanh(jnp.split(logits, 2, axis=-1)[0])
