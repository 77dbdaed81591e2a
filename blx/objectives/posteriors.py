"""Posteriors q(z | s) of MI-max objectives, the piece that tells GCRL, cDIAYN and DIAYN apart.

A ``Posterior`` bundles what an MI-max objective needs from q: its parameters, its output for one
(selected) observation, log q(z | s) from that output, the skill that best explains it, and the
reward offset that keeps r = log q + offset non-negative. The presets compose one with a prior
(``priors``) into an ``Objective``; a new posterior is a new constructor here, not a new branch in
the presets.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple, Protocol

import jax
import jax.numpy as jnp

from blx.objectives import mimax

__all__ = ["Posterior", "Network", "identity_posterior", "gaussian_posterior",
           "categorical_posterior"]


class Network(Protocol):
  """A learned discriminator: ``init(key, in_size) -> params``, ``apply(params, x) -> [Z]``,
  ``post_update(params, x_batch) -> params`` and whether it has one (``has_post_update``)."""

  has_post_update: bool

  def init(self, key: jax.Array, in_size: int) -> Any: ...
  def apply(self, params: Any, x: jax.Array) -> jax.Array: ...
  def post_update(self, params: Any, x_batch: jax.Array) -> Any: ...


class Posterior(NamedTuple):
  """q(z | s) for one observation's selected features ``x``.

  Attributes:
    kind: a label for specs and logs ("identity", "gaussian", "categorical").
    offset: the reward offset (r = log q + offset).
    init: ``(key, in_size) -> params`` ({} when nothing is learned).
    out: ``(params, x [D]) -> [Z]``, the Gaussian mean or the logits.
    log_q: ``(z [Z], out [Z]) -> []``.
    infer: ``(out [Z]) -> z [Z]``, the skill that best explains the output.
    network: the learned network, or None (nothing to train: the loss is zero).
    accuracy: ``(out [N, Z], z [N, Z]) -> []`` for a categorical posterior, else None.
  """

  kind: str
  offset: float
  init: Callable[[jax.Array, int], Any]
  out: Callable[[Any, jax.Array], jax.Array]
  log_q: Callable[[jax.Array, jax.Array], jax.Array]
  infer: Callable[[jax.Array], jax.Array]
  network: Network | None = None
  accuracy: Callable[[jax.Array, jax.Array], jax.Array] | None = None


def identity_posterior(dim: int) -> Posterior:
  """q(z | s) = N(s_idx, I): the features are the goal (GCRL); nothing is learned."""
  return Posterior(kind="identity", offset=mimax.gaussian_offset(dim), init=lambda key, n: {},
                   out=lambda params, x: x,
                   log_q=lambda z, mean: mimax.gaussian_log_q(z, mean, 1.0),
                   infer=lambda mean: mean)


def gaussian_posterior(dim: int, network: Network) -> Posterior:
  """q(z | s) = N(network(s_idx), I) (cDIAYN)."""
  return Posterior(kind="gaussian", offset=mimax.gaussian_offset(dim), init=network.init,
                   out=network.apply, log_q=lambda z, mean: mimax.gaussian_log_q(z, mean, 1.0),
                   infer=lambda mean: mean, network=network)


def categorical_posterior(dim: int, network: Network, logits_clip: float) -> Posterior:
  """q(z | s) = Cat(clip(network(s_idx))) over ``dim`` one-hot skills (DIAYN); offset = the clip."""
  return Posterior(
      kind="categorical", offset=mimax.categorical_offset(logits_clip), init=network.init,
      out=network.apply,
      log_q=lambda z, logits: mimax.categorical_log_q(z, logits, logits_clip=logits_clip),
      infer=lambda logits: jax.nn.one_hot(jnp.argmax(logits), dim), network=network,
      accuracy=lambda logits, z: jnp.mean(jnp.argmax(logits, -1) == jnp.argmax(z, -1)))
