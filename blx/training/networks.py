"""Policy and value networks, the tanh-squashed Gaussian, and the running observation normaliser."""

from __future__ import annotations

from typing import Sequence

import distrax
import flax.linen as nn
import jax
import jax.numpy as jnp

# The running normaliser is shared with the objectives' ``normalize_obs``.
from blx.running_stats import RunningStats, init_stats, normalize, update_stats

__all__ = ["MLP", "AgentMLPs", "sample_raw_action", "log_prob_raw", "entropy", "deterministic_action",
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


class AgentMLPs(nn.Module):
  """One independent MLP per agent on the same input, each writing its own outputs of one vector.

  Agent ``name`` (its parameters live under that name) computes ``len(outputs[i])`` numbers that
  land at positions ``outputs[i]`` of the ``[..., out_size]`` result; together the agents cover
  every position once. MAPPO's policy is this with each agent's action dimensions (means and
  scales), its value function with one output per agent.
  """

  hidden: Sequence[int]
  names: Sequence[str]
  outputs: Sequence[Sequence[int]]
  out_size: int

  @nn.compact
  def __call__(self, x: jax.Array) -> jax.Array:
    out = jnp.zeros(x.shape[:-1] + (self.out_size,), x.dtype)
    for name, positions in zip(self.names, self.outputs):
      y = MLP((*self.hidden, len(positions)), name=name)(x)
      out = out.at[..., jnp.asarray(positions, jnp.int32)].set(y)
    return out


# A policy outputs ``logits [..., 2A]``: the Gaussian's mean and a pre-softplus scale. Actions are
# a = tanh(u), u ~ N(mean, softplus(scale) + 0.001). Log-probabilities are taken on the raw u, where
# they are exact and stable; the tanh correction log|da/du| cancels in PPO's ratio.

def _gaussian(logits: jax.Array) -> distrax.Normal:
  loc, scale = jnp.split(logits, 2, axis=-1)
  return distrax.Normal(loc, jax.nn.softplus(scale) + 0.001)


def sample_raw_action(logits: jax.Array, key: jax.Array) -> jax.Array:
  """u ~ N(mean, std), the pre-tanh action ``[..., A]``."""
  return _gaussian(logits).sample(seed=key)


def log_prob_raw(logits: jax.Array, raw_action: jax.Array,
                 groups: jax.Array | None = None) -> jax.Array:
  """log N(u; mean, std) summed over action dimensions ``[...]``; with ``groups`` (a 0/1 matrix
  ``[A, G]`` assigning each action dimension to one of G agents), summed per agent ``[..., G]``."""
  per_dim = _gaussian(logits).log_prob(raw_action)
  return per_dim.sum(-1) if groups is None else per_dim @ groups


def entropy(logits: jax.Array, key: jax.Array) -> jax.Array:
  """Entropy of tanh(u): H[N] + E[log|d tanh(u)/du|], the expectation from one sample (as Brax)."""
  dist = _gaussian(logits)
  sample = dist.sample(seed=key)
  return (dist.entropy() + distrax.Tanh().forward_log_det_jacobian(sample)).sum(-1)


def deterministic_action(logits: jax.Array) -> jax.Array:
  """tanh(mean): the mode of the squashed policy, used for evaluation."""
  return jnp.tanh(jnp.split(logits, 2, axis=-1)[0])
