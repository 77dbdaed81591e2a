"""D-min building blocks: the binary discriminator loss, the reward transforms of its logit, the MLE
reward for a known target density, and the gradient penalty.

State-marginal matching by divergence minimisation (Braxlines paper, section 3.2, Table 1; GAIL: Ho &
Ermon 2016; AIRL: Fu et al. 2018; FAIRL: Ghasemipour et al. 2019). A discriminator with logit l(s)
estimates D(s) = sigmoid(l(s)) = P(s comes from the target); each algorithm turns the clipped logit
into a reward, offset by c = logits_clip so that rewards are (nearly) non-negative.

Every transform is written for one example; ``vmap`` it for batches.
"""

from __future__ import annotations

from typing import Any, Callable

import chex
import jax
import jax.numpy as jnp

__all__ = ["discriminator_loss", "gail_reward", "gail2_reward", "airl_reward", "fairl_reward",
           "mle_reward", "gradient_penalty"]


def discriminator_loss(logits_policy: jax.Array, logits_target: jax.Array) -> jax.Array:
  """Binary cross-entropy with policy samples labelled 0 and target samples labelled 1.

      L = -mean_i log(1 - D(x_i^pol)) - mean_j log D(x_j^tgt)
        = mean_i softplus(l_i^pol) + mean_j softplus(-l_j^tgt)

  Each class is averaged on its own before the two are added, so the classes weigh the same
  whatever their sizes (class balancing; the presets also subsample to equal sizes, as Braxlines).

  Args:
    logits_policy: ``[N]`` logits of policy samples (already clipped if clipping is wanted).
    logits_target: ``[M]`` logits of target samples.

  Returns:
    ``[]`` the loss.
  """
  chex.assert_rank([logits_policy, logits_target], 1)
  return jnp.mean(jax.nn.softplus(logits_policy)) + jnp.mean(jax.nn.softplus(-logits_target))


def gail_reward(logit: jax.Array) -> jax.Array:
  """GAIL: r = -log(1 - D) = softplus(l) >= 0 (no offset needed)."""
  chex.assert_rank(logit, 0)
  return jax.nn.softplus(logit)


def gail2_reward(logit: jax.Array, *, offset: float = 0.0) -> jax.Array:
  """GAIL2: r = log D + c = -softplus(-l) + c; for l in [-c, c] this is >= -log(1 + e^-c)."""
  chex.assert_rank(logit, 0)
  return -jax.nn.softplus(-logit) + offset


def airl_reward(logit: jax.Array, *, offset: float = 0.0) -> jax.Array:
  """AIRL: r = log D - log(1 - D) + c = l + c, >= 0 for l in [-c, c]."""
  chex.assert_rank(logit, 0)
  return logit + offset


def fairl_reward(logit: jax.Array, *, offset: float = 0.0) -> jax.Array:
  """FAIRL: r = -l e^l + c (the forward-KL reward; not bounded below by the offset)."""
  chex.assert_rank(logit, 0)
  return -logit * jnp.exp(logit) + offset


def mle_reward(log_density: jax.Array, *, offset: float = 0.0) -> jax.Array:
  """MLE (an oracle for a known target density p*): r = log p*(s) + offset."""
  chex.assert_rank(log_density, 0)
  return log_density + offset


def gradient_penalty(logit_fn: Callable[[Any, jax.Array], jax.Array], params: Any,
                     x_policy: jax.Array, x_target: jax.Array, key: jax.Array, *,
                     weight: float) -> jax.Array:
  """weight * mean_i || grad_x l(x_hat_i) ||_2 on random interpolates (Braxlines' form).

      x_hat_i = w_i x_i^pol + (1 - w_i) x_i^tgt,   w_i ~ U(0, 1)

  The norm is neither squared nor shifted by 1 (unlike WGAN-GP), as in the original.

  Args:
    logit_fn: ``(params, x [D]) -> []`` the discriminator logit for one example.
    params: its parameters (the penalty is differentiable in them).
    x_policy: ``[N, D]`` policy samples.
    x_target: ``[N, D]`` target samples (the same count).
    key: for the interpolation weights, ``w = jax.random.uniform(key, (N, 1))``.
    weight: the penalty weight.

  Returns:
    ``[]`` the penalty.
  """
  chex.assert_rank([x_policy, x_target], 2)
  chex.assert_equal_shape([x_policy, x_target])
  w = jax.random.uniform(key, (x_policy.shape[0], 1))
  x_hat = w * x_policy + (1.0 - w) * x_target
  grads = jax.vmap(jax.grad(logit_fn, argnums=1), (None, 0))(params, x_hat)
  # sqrt with a tiny floor: the gradient of ||g|| at g = 0 would otherwise be NaN.
  norms = jnp.sqrt(jnp.sum(grads**2, axis=-1) + 1e-12)
  return weight * jnp.mean(norms)
