"""MI-max building blocks: log q(z|s) for fixed-sigma Gaussian and categorical posteriors, and the
variational MI reward with its non-negativity offset.

Variational empowerment (Braxlines paper, section 3.1, Table 1; Gu et al. 2021): with a prior p(z) and
a posterior q(z|s), the lower bound I(s; z) >= E[log q(z|s) - log p(z)] gives the reward

    r_t = log q(z | s_{t+1}) + offset

where -log p(z) is dropped (constant for uniform priors) and the offset keeps rewards non-negative over
the region that matters, so that PPO does not learn to end episodes early.

Every function is written for one example; ``vmap`` it for batches.
"""

from __future__ import annotations

import math

import chex
import jax
import jax.numpy as jnp

__all__ = ["gaussian_log_q", "categorical_log_q", "clip_logits", "mimax_reward", "gaussian_offset",
           "categorical_offset"]


def gaussian_log_q(z: jax.Array, mean: jax.Array, sigma: float | jax.Array = 1.0) -> jax.Array:
  """log N(z; mean, sigma^2 I) for a diagonal Gaussian with a fixed sigma.

      log q = -1/2 sum_i ((z_i - mean_i) / sigma)^2 - d log sigma - (d/2) log 2 pi

  Args:
    z: the latent ``[d]``.
    mean: the posterior mean ``[d]`` (the indexed observation for GCRL, an MLP for cDIAYN).
    sigma: the fixed scale (1 in every Braxlines preset).

  Returns:
    ``[]`` the log-density.
  """
  chex.assert_rank([z, mean], 1)
  chex.assert_equal_shape([z, mean])
  d = z.shape[0]
  sigma = jnp.asarray(sigma, z.dtype)
  return (-0.5 * jnp.sum(((z - mean) / sigma) ** 2) - d * jnp.log(sigma)
          - 0.5 * d * math.log(2.0 * math.pi))


def clip_logits(logits: jax.Array, *, logits_clip: float) -> jax.Array:
  """Shifts logits so their max is 0, then clips them below at -logits_clip: l' = max(l - max l, -c).

  The shift leaves the softmax unchanged; the clip bounds log q(z|s) below by -c - log(K - 1 + e^-c).
  """
  chex.assert_rank(logits, 1)
  return jnp.maximum(logits - jax.lax.stop_gradient(logits.max()), -logits_clip)


def categorical_log_q(z_onehot: jax.Array, logits: jax.Array, *,
                      logits_clip: float = 5.0) -> jax.Array:
  """log q(z|s) = z . log_softmax(clip_logits(logits)) for a one-hot skill ``z [K]``.

  Args:
    z_onehot: one-hot skill ``[K]``.
    logits: the discriminator's logits ``[K]``.
    logits_clip: c; the shifted logits are clipped to [-c, 0].

  Returns:
    ``[]`` in [-c - log(K - 1 + e^-c), 0].
  """
  chex.assert_rank([z_onehot, logits], 1)
  chex.assert_equal_shape([z_onehot, logits])
  return jnp.sum(z_onehot * jax.nn.log_softmax(clip_logits(logits, logits_clip=logits_clip)))


def mimax_reward(log_q: jax.Array, *, offset: float | jax.Array) -> jax.Array:
  """r = log q(z|s') + offset (Braxlines: no -log p(z) term; the offset replaces it)."""
  chex.assert_rank(log_q, 0)
  return log_q + offset


def gaussian_offset(dim: int, sigma: float = 1.0) -> float:
  """-log N(3 sigma 1; 0, sigma^2 I) = (d/2) log 2 pi + d log sigma + 4.5 d.

  With it the reward is non-negative while the posterior mean is within 3 sigma of z in every
  dimension (for sigma = 1: r = 4.5 d - 1/2 ||z - mean||^2).
  """
  if dim < 1 or sigma <= 0:
    raise ValueError(f"gaussian_offset: need dim >= 1 and sigma > 0, got dim={dim}, sigma={sigma}")
  return 0.5 * dim * math.log(2.0 * math.pi) + dim * math.log(sigma) + 4.5 * dim


def categorical_offset(logits_clip: float) -> float:
  """The categorical offset is the clip c: r = log q + c.

  r = c - log K when the discriminator cannot tell the K skills apart, up to
  c - log(1 + (K-1) e^-c) when it is certain, and down to -log(K - 1 + e^-c) when z's logit is
  clipped and all others tie (so the reward is non-negative unless the discriminator is confidently
  wrong).
  """
  return float(logits_clip)
