"""Stationary metrics of behaviour from samples (Braxlines paper, section 4.3; Algorithms 1 and 3).

All functions are pure, jit-able and take plain arrays: they know nothing of envs or policies.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp

__all__ = ["entropy", "entropy_2d", "mutual_information", "mutual_information_2d",
           "latent_goal_reaching", "energy_distance", "state_coverage"]

_EPS = 1e-12


def _bin_index(x: jax.Array, bins: int, value_range) -> tuple[jax.Array, jax.Array]:
  """Bin of each sample on ``bins`` equal bins over [lo, hi] (hi in the last bin) and whether the
  sample is in range at all."""
  lo, hi = value_range
  inside = (x >= lo) & (x <= hi)
  idx = jnp.clip(jnp.floor((x - lo) / (hi - lo) * bins).astype(jnp.int32), 0, bins - 1)
  return idx, inside


def _entropy_of_counts(counts: jax.Array, total: jax.Array) -> jax.Array:
  p = counts / jnp.maximum(total, 1.0)
  return -jnp.sum(p * jnp.log(p + _EPS), axis=-1)


def entropy(x: jax.Array, *, bins: int = 1000, value_range=(-1.0, 1.0)) -> jax.Array:
  """Histogram entropy H = -sum_b p_b log(p_b + 1e-12) of 1-D samples ``x [N]``.

  p_b = count_b / N with N all samples: out-of-range samples count in N but fall in no bin, as in
  Braxlines' estimator. A uniform histogram over all bins gives log(bins).
  """
  chex.assert_rank(x, 1)
  idx, inside = _bin_index(x, bins, value_range)
  counts = jnp.zeros(bins).at[idx].add(inside.astype(jnp.float32))
  return _entropy_of_counts(counts, jnp.asarray(x.shape[0], jnp.float32))


def entropy_2d(x: jax.Array, *, bins: int = 30, value_range=(-1.0, 1.0)) -> jax.Array:
  """Histogram entropy of 2-D samples ``x [N, 2]`` on ``bins x bins`` cells over value_range^2."""
  chex.assert_rank(x, 2)
  chex.assert_axis_dimension(x, 1, 2)
  idx, inside = _bin_index(x, bins, value_range)
  flat = idx[:, 0] * bins + idx[:, 1]
  counts = jnp.zeros(bins * bins).at[flat].add(inside.all(-1).astype(jnp.float32))
  return _entropy_of_counts(counts, jnp.asarray(x.shape[0], jnp.float32))


def _mi(flat_idx, inside, labels, num_labels, num_cells, weights):
  """MI, H(s), mean_z H(s|z) of binned samples, each sample counting ``weights`` (in range or not:
  the out-of-range ones count in the totals but fall in no bin)."""
  total = jnp.zeros(num_cells).at[flat_idx].add(inside * weights)
  h_all = _entropy_of_counts(total, weights.sum())
  per_label = jnp.zeros((num_labels, num_cells)).at[labels, flat_idx].add(inside * weights)
  n_label = jnp.zeros(num_labels).at[labels].add(weights)
  h_cond = _entropy_of_counts(per_label, n_label[:, None])
  present = n_label > 0
  h_z = jnp.sum(jnp.where(present, h_cond, 0.0)) / jnp.maximum(present.sum(), 1)
  return h_all - h_z, h_all, h_z


def _num_labels(labels, num_labels):
  if num_labels is None:
    try:
      return int(jnp.max(labels)) + 1
    except jax.errors.ConcretizationTypeError as e:
      raise ValueError("mutual_information: pass num_labels when calling under jit") from e
  return int(num_labels)


def _weights(weights, n):
  if weights is None:
    return jnp.ones(n, jnp.float32)
  chex.assert_shape(weights, (n,))
  return jnp.asarray(weights, jnp.float32)


def mutual_information(x: jax.Array, labels: jax.Array, *, bins: int = 1000,
                       value_range=(-1.0, 1.0), num_labels: int | None = None,
                       weights: jax.Array | None = None) -> dict:
  """Particle estimate of I(s; z) per dimension (paper Algorithm 1):

      MI_d = H(s_d) - mean_z H(s_d | z)

  with histogram entropies on ``bins`` bins over ``value_range`` (the same edges for all).

  Args:
    x: samples ``[N, D]`` (or ``[N]``).
    labels: the skill of each sample ``[N]``, ints in 0..num_labels-1.
    num_labels: number of skills (static; inferred from ``labels`` outside jit).
    weights: each sample's weight ``[N]`` (default 1): a 0/1 mask estimates the MI of the kept
      samples alone (a skill with none kept drops out of the mean over z).

  Returns:
    ``{"mi": [D], "entropy": [D] (H(s)), "conditional_entropy": [D] (mean_z H(s|z))}``.
  """
  x = x[:, None] if x.ndim == 1 else x
  chex.assert_rank([x, labels], [2, 1])
  chex.assert_equal_shape_prefix([x, labels], 1)
  k = _num_labels(labels, num_labels)
  idx, inside = _bin_index(x, bins, value_range)
  w = _weights(weights, x.shape[0])
  fn = lambda i, m: _mi(i, m.astype(jnp.float32), labels, k, bins, w)
  mi, h, hz = jax.vmap(fn, in_axes=(1, 1))(idx, inside)
  return {"mi": mi, "entropy": h, "conditional_entropy": hz}


def mutual_information_2d(x: jax.Array, labels: jax.Array, *, bins: int = 30,
                          value_range=(-1.0, 1.0), num_labels: int | None = None) -> dict:
  """As ``mutual_information`` on the joint histogram of a pair of dimensions ``x [N, 2]``."""
  chex.assert_rank([x, labels], [2, 1])
  chex.assert_axis_dimension(x, 1, 2)
  k = _num_labels(labels, num_labels)
  idx, inside = _bin_index(x, bins, value_range)
  flat = idx[:, 0] * bins + idx[:, 1]
  mi, h, hz = _mi(flat, inside.all(-1).astype(jnp.float32), labels, k, bins * bins,
                  jnp.ones(x.shape[0], jnp.float32))
  return {"mi": mi, "entropy": h, "conditional_entropy": hz}


def latent_goal_reaching(states: jax.Array, goals: jax.Array, *,
                         last_steps: int | None = None) -> dict:
  """Latent goal reaching (paper Algorithm 2; Choi et al., 2021).

  For each goal g, episodes reached with the latent inferred from g: over the last ``last_steps``
  steps, ``lgr = mean_{g,m,t} sqrt(mean_i (s_i - g_i)^2)`` and ``lgr_1d_i = mean_{g,m,t}
  |s_i - g_i|``. Lower is better (the paper's tables report -LGR).

  Args:
    states: feature states ``[G, M, T, D]`` (goals, episodes per goal, time, dims).
    goals: ``[G, D]``.
  """
  chex.assert_rank([states, goals], [4, 2])
  if last_steps is not None:
    states = states[:, :, -last_steps:]
  diff = states - goals[:, None, None, :]
  return {"lgr": jnp.mean(jnp.sqrt(jnp.mean(diff**2, -1))),
          "lgr_1d": jnp.mean(jnp.abs(diff), axis=(0, 1, 2))}


def _mean_pairwise_distance(a: jax.Array, b: jax.Array, block: int, wa: jax.Array,
                            wb: jax.Array) -> jax.Array:
  """sum_{i,j} wa_i wb_j ||a_i - b_j|| / (sum wa sum wb) computed block by block: memory
  O(block^2), not O(N M). An array shorter than ``block`` is one block of its own length, so small
  inputs are not padded to ``block``."""
  def pad(x, w):
    n = x.shape[0]
    size = min(block, n)
    blocks = -(-n // size)
    x = jnp.pad(x, ((0, blocks * size - n), (0, 0)))
    w = jnp.pad(w.astype(x.dtype), (0, blocks * size - n))  # padding weighs 0
    return x.reshape(blocks, size, -1), w.reshape(blocks, size)

  a_blocks, a_weights = pad(a, wa)
  b_blocks, b_weights = pad(b, wb)

  def row(args):
    xa, va = args

    def col(args):
      xb, vb = args
      d = jnp.sqrt(jnp.maximum(jnp.sum((xa[:, None] - xb[None]) ** 2, -1), 0.0))
      return jnp.sum(d * va[:, None] * vb[None])
    return jnp.sum(jax.lax.map(col, (b_blocks, b_weights)))

  total = jnp.sum(jax.lax.map(row, (a_blocks, a_weights)))
  return total / (jnp.sum(wa) * jnp.sum(wb))


def energy_distance(x: jax.Array, y: jax.Array, *, weights: jax.Array | None = None,
                    block_size: int = 1024) -> jax.Array:
  """Energy distance (paper Algorithm 3; Szekely and Rizzo):

      D = 2 E||X - Y|| - E||X - X'|| - E||Y - Y'||

  with full pairwise means, diagonals included (the V-statistic, as Braxlines). ``x [N, D]``,
  ``y [M, D]`` (1-D inputs are treated as D = 1); computed blockwise in ``block_size`` blocks.
  ``weights [N]`` (>= 0) weigh the samples of ``x`` in the means; 0/1 weights give the energy
  distance of the kept samples alone, with a count that jit need not know (NaN when none is
  kept).
  """
  x = x[:, None] if x.ndim == 1 else x
  y = y[:, None] if y.ndim == 1 else y
  chex.assert_rank([x, y], 2)
  chex.assert_equal_shape_suffix([x, y], 1)
  if not (x.shape[0] and y.shape[0]):
    raise ValueError(f"energy_distance: x and y need at least one sample each, got {x.shape[0]} "
                     f"and {y.shape[0]}")
  if isinstance(block_size, bool) or not isinstance(block_size, int) or block_size < 1:
    raise ValueError(f"energy_distance: block_size must be an int >= 1, got {block_size!r}")
  wx = _weights(weights, x.shape[0])
  wy = jnp.ones(y.shape[0])
  mpd = lambda a, b, wa, wb: _mean_pairwise_distance(a, b, block_size, wa, wb)
  return 2.0 * mpd(x, y, wx, wy) - mpd(x, x, wx, wx) - mpd(y, y, wy, wy)


def state_coverage(xy: jax.Array, *, cell: float = 1.0) -> jax.Array:
  """Number of distinct ``cell x cell`` squares of a 2-D feature space visited by ``xy [N, 2]``."""
  chex.assert_rank(xy, 2)
  chex.assert_axis_dimension(xy, 1, 2)
  ij = jnp.floor(xy / cell).astype(jnp.int32)
  order = jnp.lexsort((ij[:, 1], ij[:, 0]))
  ij = ij[order]
  new = jnp.any(ij[1:] != ij[:-1], axis=-1)
  return 1 + jnp.sum(new)
