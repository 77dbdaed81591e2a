"""Closed forms and independent numpy references for the particle metrics."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import metrics


def test_uniform_histogram_has_entropy_log_bins():
  # One sample at the centre of each of 100 bins on [-1, 1]: p_b = 1/100, H = log 100.
  x = -1 + (np.arange(100) + 0.5) * 0.02
  assert float(metrics.entropy(jnp.asarray(x), bins=100)) == pytest.approx(np.log(100), rel=1e-5)


def test_out_of_range_samples_count_in_n_but_in_no_bin():
  # 2 samples in one bin, 2 outside: p = 2/4 in one bin, H = -0.5 log 0.5 = 0.3466.
  x = jnp.array([0.1, 0.1, 5.0, -7.0])
  assert float(metrics.entropy(x, bins=10)) == pytest.approx(-0.5 * np.log(0.5), rel=1e-5)


def test_entropy_matches_numpy_histogram():
  x = np.random.default_rng(0).normal(0, 0.3, 5000)
  counts, _ = np.histogram(x, bins=50, range=(-1, 1))
  p = counts / x.size
  expected = -np.sum(p * np.log(p + 1e-12))
  assert float(metrics.entropy(jnp.asarray(x), bins=50)) == pytest.approx(expected, rel=1e-4)
  xy = np.random.default_rng(1).uniform(-1, 1, (4000, 2))
  counts2, _, _ = np.histogram2d(xy[:, 0], xy[:, 1], bins=20, range=[(-1, 1), (-1, 1)])
  p2 = counts2.ravel() / len(xy)
  assert float(metrics.entropy_2d(jnp.asarray(xy), bins=20)) == pytest.approx(
      -np.sum(p2 * np.log(p2 + 1e-12)), rel=1e-4)


def test_skills_in_disjoint_bins_give_mi_log_k():
  k = 4
  labels = np.repeat(np.arange(k), 50)
  x = (labels[:, None] - 1.5) * 0.4 + np.zeros((1, 2))  # skill j sits at its own point
  out = metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), bins=100)
  np.testing.assert_allclose(out["mi"], [np.log(k)] * 2, rtol=1e-5)
  np.testing.assert_allclose(out["conditional_entropy"], [0, 0], atol=1e-6)


def test_identical_conditionals_give_mi_zero():
  rng = np.random.default_rng(0)
  x = np.tile(rng.uniform(-1, 1, 200), 3)  # the same samples for each of 3 skills
  labels = np.repeat(np.arange(3), 200)
  out = metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), bins=20)
  assert float(out["mi"][0]) == pytest.approx(0.0, abs=1e-5)
  out2 = metrics.mutual_information_2d(jnp.stack([jnp.asarray(x)] * 2, -1), jnp.asarray(labels),
                                       bins=10)
  assert float(out2["mi"]) == pytest.approx(0.0, abs=1e-5)


def test_a_zero_one_weight_estimates_the_mi_of_the_kept_samples_alone():
  # Four skills at their own points, plus "fallen" samples that every skill shares at 0.9: the
  # mask that keeps the skills' own samples gives log 4, as if the fallen ones were never taken,
  # while the whole set mixes each skill with the shared point.
  k = 4
  own = np.repeat(np.arange(k), 30)
  x = np.concatenate([(own - 1.5) * 0.4, np.full(k * 20, 0.9)])
  labels = np.concatenate([own, np.repeat(np.arange(k), 20)])
  keep = np.concatenate([np.ones(k * 30), np.zeros(k * 20)])
  kept = metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), bins=100,
                                    weights=jnp.asarray(keep))
  alone = metrics.mutual_information(jnp.asarray(x[keep == 1]), jnp.asarray(own), bins=100)
  np.testing.assert_allclose(kept["mi"], [np.log(k)], rtol=1e-5)
  for name in ("mi", "entropy", "conditional_entropy"):
    np.testing.assert_allclose(kept[name], alone[name], rtol=1e-5)
  whole = metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), bins=100)
  assert float(whole["mi"][0]) < np.log(k) - 0.3
  # Unit weights are the default; a skill with no kept sample drops out of the mean over z.
  ones = metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), bins=100,
                                    weights=jnp.ones(len(x)))
  np.testing.assert_allclose(ones["mi"], whole["mi"], rtol=1e-6)
  drop = metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), bins=100,
                                    weights=jnp.asarray(keep * (labels != 3)))
  np.testing.assert_allclose(drop["mi"], [np.log(3)], rtol=1e-5)
  with pytest.raises(AssertionError):
    metrics.mutual_information(jnp.asarray(x), jnp.asarray(labels), weights=jnp.ones(3))


def test_mutual_information_under_jit_needs_num_labels():
  x, labels = jnp.zeros((6, 1)), jnp.array([0, 0, 1, 1, 2, 2])
  fn = jax.jit(lambda x, l: metrics.mutual_information(x, l, bins=4, num_labels=3)["mi"])
  assert float(fn(x, labels)[0]) == pytest.approx(0.0, abs=1e-6)
  with pytest.raises(ValueError, match="num_labels"):
    jax.jit(lambda x, l: metrics.mutual_information(x, l, bins=4)["mi"])(x, labels)


def test_latent_goal_reaching_hand_computed():
  goals = jnp.array([[0.0, 0.0], [1.0, 1.0]])
  states = jnp.zeros((2, 1, 3, 2))
  states = states.at[0, 0].set(jnp.array([[9.0, 9.0], [3.0, 4.0], [3.0, 4.0]]))
  states = states.at[1, 0].set(jnp.array([[9.0, 9.0], [1.0, 1.0], [1.0, 3.0]]))
  out = metrics.latent_goal_reaching(states, goals, last_steps=2)
  # goal 0: sqrt((9 + 16) / 2) = 3.5355 twice; goal 1: 0 and sqrt((0 + 4) / 2) = 1.4142
  # lgr = (3.5355 * 2 + 0 + 1.4142) / 4 = 2.1213; lgr_1d = ((3 + 3 + 0 + 0) / 4, (4 + 4 + 0 + 2) / 4)
  assert float(out["lgr"]) == pytest.approx((2 * np.sqrt(12.5) + np.sqrt(2)) / 4, rel=1e-6)
  np.testing.assert_allclose(out["lgr_1d"], [1.5, 2.5], rtol=1e-6)


def _energy_numpy(x, y):
  d = lambda a, b: np.linalg.norm(a[:, None] - b[None], axis=-1).mean()
  return 2 * d(x, y) - d(x, x) - d(y, y)


@pytest.mark.parametrize("dim", [1, 2, 5])
def test_energy_distance_matches_direct_numpy(dim):
  rng = np.random.default_rng(dim)
  x, y = rng.normal(0, 1, (300, dim)), rng.normal(0.5, 2, (170, dim))
  expected = _energy_numpy(x, y)
  got = metrics.energy_distance(jnp.asarray(x), jnp.asarray(y), block_size=64)  # blockwise
  assert float(got) == pytest.approx(expected, rel=1e-4)
  direct = metrics.energy_distance(jnp.asarray(x), jnp.asarray(y), block_size=1024)  # one block
  assert float(got) == pytest.approx(float(direct), rel=1e-5)


def test_energy_distance_refuses_an_empty_sample_or_block():
  x = jnp.ones((3, 2))
  with pytest.raises(ValueError, match="at least one sample each, got 0 and 3"):
    metrics.energy_distance(jnp.ones((0, 2)), x)
  for bad in (0, 2.5):
    with pytest.raises(ValueError, match="block_size must be an int >= 1"):
      metrics.energy_distance(x, x, block_size=bad)


def test_energy_distance_properties():
  rng = np.random.default_rng(0)
  x, y = jnp.asarray(rng.normal(0, 1, (200, 2))), jnp.asarray(rng.normal(0, 1, (150, 2)))
  assert float(metrics.energy_distance(x, x)) == pytest.approx(0.0, abs=1e-5)
  assert float(metrics.energy_distance(x, y)) == pytest.approx(
      float(metrics.energy_distance(y, x)), rel=1e-5)
  shifts = [float(metrics.energy_distance(x, y + s)) for s in (0.0, 1.0, 3.0)]
  assert shifts[0] < shifts[1] < shifts[2]


def test_state_coverage_counts_distinct_cells():
  xy = jnp.array([[0.1, 0.2], [0.9, 0.9], [1.5, 0.1], [-0.5, 0.2], [1.2, 0.7], [5.0, 5.0]])
  # cells: (0,0), (0,0), (1,0), (-1,0), (1,0), (5,5) -> 4 distinct
  assert int(metrics.state_coverage(xy)) == 4
  assert int(metrics.state_coverage(xy, cell=10.0)) == 2  # (0,0) and (-1,0)


def test_weighted_energy_distance_is_that_of_the_kept_samples():
  x = jax.random.normal(jax.random.PRNGKey(0), (40, 2))
  y = jax.random.normal(jax.random.PRNGKey(1), (30, 2)) + 1.0
  keep = (jnp.arange(40) % 3 == 0).astype(jnp.float32)
  np.testing.assert_allclose(metrics.energy_distance(x, y, weights=keep, block_size=8),
                             metrics.energy_distance(x[::3], y), rtol=1e-5)
  # Integer weights count a sample that many times.
  twice = jnp.concatenate([x, x[:5]])
  np.testing.assert_allclose(
      metrics.energy_distance(x, y, weights=jnp.ones(40).at[:5].set(2.0)),
      metrics.energy_distance(twice, y), rtol=1e-5)
  assert np.isnan(metrics.energy_distance(x, y, weights=jnp.zeros(40)))
