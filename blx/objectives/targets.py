"""Target distributions for D-min: Braxlines' multimodal Gaussian mixtures, or user samples."""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import distrax
import jax
import jax.numpy as jnp
import numpy as np

__all__ = ["Target", "multimode_gaussian", "target_from_samples"]


class Target(NamedTuple):
  """A target state distribution.

  Attributes:
    samples: ``[M, D]`` the fixed samples the discriminator trains on (and metrics compare to).
    log_prob: ``x [D] -> []`` the density when it is known (needed by ``mle``), else None.
    name: a label for plots and logs.
    means: ``[K, D]`` the centres of the target's modes when it has known modes (a mixture), else
      None; evaluation then reports how the policy's samples share out among them.
  """

  samples: jax.Array
  log_prob: Callable[[jax.Array], jax.Array] | None
  name: str
  means: jax.Array | None = None

  @property
  def dim(self) -> int:
    return int(self.samples.shape[-1])


def multimode_gaussian(num_modes: int = 2, *, scale: float, dim: int, num_samples: int = 250,
                       seed: int = 0) -> Target:
  """An equal-weight Gaussian mixture with Braxlines' layout.

  * 1-D: means at the interior points of linspace(-scale, scale, n + 2), std scale / (n + 1) / 5;
    e.g. scale 8, 2 modes: means +-2.67, std 0.53.
  * 2-D: means on a circle of radius scale / 2 at angles 2 pi k / n, std scale / 10 per dimension;
    e.g. scale 8, 2 modes: means (4, 0) and (-4, 0), std 0.8.

  Args:
    num_modes: n >= 1.
    scale: the observation scale (``obs_scale``).
    dim: 1 or 2, the number of indexed observation dimensions.
    num_samples: how many samples to draw once, with ``seed`` (Braxlines: 250).
    seed: the PRNG seed of the samples.
  """
  if not isinstance(num_modes, int) or isinstance(num_modes, bool) or num_modes < 1:
    raise ValueError(f"multimode_gaussian: num_modes must be an int >= 1, got {num_modes!r}")
  if isinstance(scale, (str, bool)) or not scale > 0:
    raise ValueError(f"multimode_gaussian: scale must be > 0, got {scale}")
  if dim == 1:
    means = np.linspace(-scale, scale, num_modes + 2)[1:-1, None]
    std = scale / (num_modes + 1) / 5.0
  elif dim == 2:
    angles = 2.0 * math.pi * np.arange(num_modes) / num_modes
    means = 0.5 * scale * np.stack([np.cos(angles), np.sin(angles)], -1)
    std = scale / 10.0
  else:
    raise ValueError(f"multimode_gaussian: dim must be 1 or 2 (Braxlines' layouts), got {dim}; "
                     "for other targets use target_from_samples")
  means = jnp.asarray(means, jnp.float32)
  mixture = distrax.MixtureSameFamily(
      mixture_distribution=distrax.Categorical(logits=jnp.zeros(num_modes)),
      components_distribution=distrax.MultivariateNormalDiag(
          means, jnp.full_like(means, std)))
  samples = mixture.sample(seed=jax.random.PRNGKey(seed), sample_shape=(num_samples,))
  return Target(samples=samples, log_prob=mixture.log_prob,
                name=f"{num_modes}-mode gaussian (scale {scale:g}, {dim}-D)", means=means)


def target_from_samples(samples, *, name: str = "samples") -> Target:
  """A target given by samples ``[M, D]`` only (no density: ``mle`` cannot use it)."""
  samples = jnp.asarray(samples, jnp.float32)
  if samples.ndim == 1:
    samples = samples[:, None]
  if samples.ndim != 2 or samples.shape[0] < 2:
    raise ValueError(f"target_from_samples: need samples of shape [M >= 2, D], got {samples.shape}")
  if not bool(jnp.isfinite(samples).all()):
    raise ValueError("target_from_samples: the samples contain NaN or inf")
  return Target(samples=samples, log_prob=None, name=name)
