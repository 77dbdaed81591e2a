"""Priors p(z) over skills (Braxlines: ``Uniform``, ``UniformCategorial``, ``Deterministic``).

A ``Prior`` is a sampler and a log-probability, both for one example, backed by distrax.
"""

from __future__ import annotations

from typing import Callable, NamedTuple, Sequence

import distrax
import jax
import jax.numpy as jnp

__all__ = ["Prior", "uniform_prior", "categorical_prior", "deterministic_prior", "MAX_SKILLS"]

MAX_SKILLS = 65_536  # one-hot skills beyond this would not fit a discriminator's output anyway


class Prior(NamedTuple):
  """p(z): ``sample(key) -> z [dim]`` and ``log_prob(z [dim]) -> []``; ``kind`` names the family."""

  sample: Callable[[jax.Array], jax.Array]
  log_prob: Callable[[jax.Array], jax.Array]
  dim: int
  kind: str


def uniform_prior(low: float, high: float, dim: int) -> Prior:
  """Uniform on the box [low, high]^dim: log p = -dim log(high - low) inside, -inf outside."""
  if not isinstance(dim, int) or dim < 1 or not high > low:
    raise ValueError(f"uniform_prior: need dim >= 1 and high > low, got {low}, {high}, {dim}")
  dist = distrax.Independent(distrax.Uniform(jnp.full((dim,), float(low)),
                                             jnp.full((dim,), float(high))), 1)
  return Prior(sample=lambda key: dist.sample(seed=key), log_prob=dist.log_prob, dim=dim,
               kind="uniform")


def categorical_prior(num_skills: int) -> Prior:
  """Uniform over ``num_skills`` one-hot skills: log p = -log K."""
  if (not isinstance(num_skills, int) or isinstance(num_skills, bool)
      or not 2 <= num_skills <= MAX_SKILLS):
    raise ValueError(f"categorical_prior: num_skills must be an int in 2..{MAX_SKILLS} (a skill is "
                     f"a one-hot vector of that size), got {num_skills!r}")
  dist = distrax.OneHotCategorical(logits=jnp.zeros(num_skills), dtype=jnp.float32)
  return Prior(sample=lambda key: dist.sample(seed=key), log_prob=dist.log_prob, dim=num_skills,
               kind="categorical")


def deterministic_prior(value: Sequence[float] | jax.Array) -> Prior:
  """Always ``value``: log p = 0 at value, -inf elsewhere (fixed-goal GCRL)."""
  value = jnp.atleast_1d(jnp.asarray(value, jnp.float32))
  if value.ndim != 1:
    raise ValueError(f"deterministic_prior: value must be a vector, got shape {value.shape}")
  dist = distrax.Independent(distrax.Deterministic(value), 1)
  return Prior(sample=lambda key: value, log_prob=dist.log_prob, dim=value.shape[0],
               kind="deterministic")
