"""Spectral normalisation (Miyato et al. 2018) and the discriminator MLP that can use it.

``spectral_normalize`` is a pure function: the power-iteration vector u is an explicit input and
output. In ``SNDense`` it lives in the flax collection ``"spectral"``; ``apply`` runs one iteration
from the stored u inside the call, without storing it. Left alone, u stays the vector drawn at init,
so every call estimates sigma(W) with one iteration from the same start: Braxlines' spectral norm
(the presets' default, ``spectral_iteration="fixed"``). Applying with ``update_stats=True,
mutable=["spectral"]`` returns the advanced u; an objective's ``post_update`` writes it back after
every SGD step with ``spectral_iteration="persistent"``, and sigma(W) converges to the exact largest
singular value (a tighter constraint than the original's).
"""

from __future__ import annotations

from typing import Sequence

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp

__all__ = ["spectral_normalize", "SNDense", "DiscriminatorMLP"]


def _unit(x: jax.Array, eps: float) -> jax.Array:
  return x / (jnp.linalg.norm(x) + eps)


def spectral_normalize(w: jax.Array, u: jax.Array, *, num_iterations: int = 1,
                       eps: float = 1e-4) -> tuple[jax.Array, jax.Array, jax.Array]:
  """W / sigma(W), with sigma(W) the largest singular value estimated by power iteration.

      v <- W u / ||W u||,   u <- W^T v / ||W^T v||   (num_iterations times),   sigma = v^T W u

  u and v carry no gradient; sigma does (through W), as in Miyato et al.

  Args:
    w: the kernel ``[I, O]``.
    u: the current right singular vector estimate ``[O]``.
    num_iterations: power iterations from u.
    eps: added to norms.

  Returns:
    ``(w / sigma [I, O], u_next [O], sigma [])``.
  """
  chex.assert_rank([w, u], [2, 1])
  chex.assert_axis_dimension(u, 0, w.shape[1])
  w_const = jax.lax.stop_gradient(w)
  u = jax.lax.stop_gradient(u)
  v = _unit(w_const @ u, eps)
  for _ in range(num_iterations):
    v = _unit(w_const @ u, eps)
    u = _unit(w_const.T @ v, eps)
  sigma = v @ w @ u
  return w / sigma, u, sigma


class SNDense(nn.Module):
  """A dense layer, optionally spectrally normalised (lecun-uniform kernel, zero bias)."""

  features: int
  spectral_norm: bool = False
  num_iterations: int = 1
  eps: float = 1e-4

  @nn.compact
  def __call__(self, x: jax.Array, update_stats: bool = False) -> jax.Array:
    kernel = self.param("kernel", nn.initializers.lecun_uniform(), (x.shape[-1], self.features))
    bias = self.param("bias", nn.initializers.zeros, (self.features,))
    if self.spectral_norm:
      u = self.variable("spectral", "u", lambda: _unit(
          jax.random.normal(self.make_rng("params"), (self.features,)), self.eps))
      kernel, u_next, _ = spectral_normalize(kernel, u.value, num_iterations=self.num_iterations,
                                             eps=self.eps)
      if update_stats and not self.is_initializing():
        u.value = u_next
    return x @ kernel + bias


class DiscriminatorMLP(nn.Module):
  """Braxlines' discriminator: dense layers ``hidden + (out,)`` with swish between them."""

  out: int
  hidden: Sequence[int] = (32, 32)
  spectral_norm: bool = False

  @nn.compact
  def __call__(self, x: jax.Array, update_stats: bool = False) -> jax.Array:
    sizes = (*self.hidden, self.out)
    for i, size in enumerate(sizes):
      x = SNDense(size, spectral_norm=self.spectral_norm)(x, update_stats)
      if i < len(sizes) - 1:
        x = nn.swish(x)
    return x
