"""GAE and the clipped surrogate against hand-computed values."""

import jax.numpy as jnp
import numpy as np
import pytest

from blx.training import clipped_surrogate, gae
from blx.training.losses import sequence_advantages
from blx.training.networks import init_stats, normalize, update_stats


def test_gae_hand_computed_with_truncation_and_termination():
  # discount 0.9, lambda 0.5; three steps: normal, truncated (done, bootstrap), terminated.
  r = jnp.array([1.0, 2.0, 3.0])
  v = jnp.array([0.5, 1.0, 1.5])
  nv = jnp.array([1.0, 4.0, 7.0])          # V(s'_t); s'_1 is the pre-reset state of a truncation
  term = jnp.array([0.0, 0.0, 1.0])
  done = jnp.array([0.0, 1.0, 1.0])
  adv, target = gae(r, v, nv, term, done, discount=0.9, lam=0.5)
  # delta_2 = 3 + 0 - 1.5 = 1.5                      A_2 = 1.5
  # delta_1 = 2 + 0.9 * 4 - 1.0 = 4.6                A_1 = 4.6 (done: recursion stops)
  # delta_0 = 1 + 0.9 * 1 - 0.5 = 1.4                A_0 = 1.4 + 0.45 * 4.6 = 3.47
  np.testing.assert_allclose(adv, [3.47, 4.6, 1.5], rtol=1e-6)
  np.testing.assert_allclose(target, [3.97, 5.6, 3.0], rtol=1e-6)


def test_gae_unknown_bootstrap_teaches_nothing_at_that_step():
  # As above, but V(s'_1) is unknown (known_t = 0: a mid-sequence truncation whose next entry is
  # already the reset state): delta_1 = 0, so A_1 = 0, its target is V(s_1) = 1.0, and A_0 no
  # longer receives 0.45 * A_1.
  r, v = jnp.array([1.0, 2.0, 3.0]), jnp.array([0.5, 1.0, 1.5])
  nv = jnp.array([1.0, 123.0, 7.0])
  adv, target = gae(r, v, nv, jnp.array([0.0, 0.0, 1.0]), jnp.array([0.0, 1.0, 1.0]),
                    discount=0.9, lam=0.5, known_t=jnp.array([1.0, 0.0, 1.0]))
  np.testing.assert_allclose(adv, [1.4, 0.0, 1.5], rtol=1e-6)
  np.testing.assert_allclose(target, [1.9, 1.0, 3.0], rtol=1e-6)


def test_sequence_advantages_bootstrap_at_truncations():
  # Two sequences of T = 3 from auto-reset envs, discount 0.9, lambda 0.5; values[:, 3] = V(s'_2).
  r = jnp.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])
  values = jnp.array([[0.5, 1.0, 1.5, 7.0], [0.5, 1.0, 1.5, 7.0]])
  # Sequence 0: truncated at t = 1 (inside: s_2 is the reset state, V(s'_1) unknown) and at t = 2
  # (last: bootstrap from V(s'_2) = 7). Sequence 1: terminated at t = 2 (no bootstrap).
  done = jnp.array([[0.0, 1.0, 1.0], [0.0, 0.0, 1.0]])
  truncation = jnp.array([[0.0, 1.0, 1.0], [0.0, 0.0, 0.0]])
  adv, target = sequence_advantages(r, values, done, truncation, discount=0.9, lam=0.5)
  # Seq 0: delta_2 = 3 + 0.9 * 7 - 1.5 = 7.8; delta_1 = 0 (unknown); delta_0 = 1 + 0.9 - 0.5 = 1.4
  #        A = [1.4 + 0.45 * 0, 0, 7.8]
  # Seq 1: delta_2 = 3 - 1.5 = 1.5; delta_1 = 2 + 0.9 * 1.5 - 1 = 2.35; delta_0 = 1.4
  #        A_1 = 2.35 + 0.45 * 1.5 = 3.025; A_0 = 1.4 + 0.45 * 3.025 = 2.76125
  np.testing.assert_allclose(adv, [[1.4, 0.0, 7.8], [2.76125, 3.025, 1.5]], rtol=1e-6)
  np.testing.assert_allclose(target, adv + values[:, :3], rtol=1e-6)


def test_clipped_surrogate_hand_computed():
  logp_old = jnp.zeros(3)
  logp = jnp.log(jnp.array([1.5, 0.5, 1.1]))
  adv = jnp.array([1.0, -2.0, 3.0])
  # eps 0.2: min(1.5 * 1, 1.2 * 1) = 1.2; min(0.5 * -2, 0.8 * -2) = -1.6; min(3.3, 3.3) = 3.3
  # loss = -(1.2 - 1.6 + 3.3) / 3 = -0.9666...
  assert float(clipped_surrogate(logp, logp_old, adv, epsilon=0.2)) == pytest.approx(-2.9 / 3)


def test_running_stats_match_numpy():
  rng = np.random.default_rng(0)
  a, b = rng.normal(2.0, 3.0, (50, 4)), rng.normal(-1.0, 0.5, (70, 4))
  stats = update_stats(update_stats(init_stats(4), jnp.asarray(a)), jnp.asarray(b))
  both = np.concatenate([a, b])
  np.testing.assert_allclose(stats.mean, both.mean(0), rtol=1e-4)
  np.testing.assert_allclose(stats.m2 / stats.count, both.var(0), rtol=1e-4)
  x = jnp.asarray(both[:3])
  np.testing.assert_allclose(normalize(stats, x), np.clip((both[:3] - both.mean(0)) / both.std(0),
                                                          -5, 5), rtol=1e-3, atol=1e-4)
