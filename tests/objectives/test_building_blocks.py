"""The objectives' building blocks against hand-computed values and independent references."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import objectives as O

LOG_2PI = math.log(2 * math.pi)


def test_gaussian_log_q():
  # z = (1, 2), mean 0, sigma 1: -1/2 (1 + 4) - 0 - (2/2) log 2 pi = -2.5 - 1.837877
  np.testing.assert_allclose(O.gaussian_log_q(jnp.array([1.0, 2.0]), jnp.zeros(2)),
                             -2.5 - LOG_2PI, rtol=1e-6)
  # sigma 2: -1/2 (0.25 + 1) - 2 log 2 - log 2 pi
  np.testing.assert_allclose(O.gaussian_log_q(jnp.array([1.0, 2.0]), jnp.zeros(2), 2.0),
                             -0.625 - 2 * math.log(2) - LOG_2PI, rtol=1e-6)


def test_gaussian_offset_makes_rewards_non_negative_within_three_sigma():
  # (d/2) log 2 pi + d log sigma + 4.5 d, d = 2: log 2 pi + 9
  offset = O.gaussian_offset(2)
  np.testing.assert_allclose(offset, LOG_2PI + 9.0, rtol=1e-6)
  z = jnp.array([0.5, -1.0])
  # |z - mean| = 3 in every dimension: exactly 0; anywhere inside the 3-sigma box: positive.
  np.testing.assert_allclose(O.mimax_reward(O.gaussian_log_q(z, z + 3.0), offset=offset), 0.0,
                             atol=1e-5)
  means = jax.random.uniform(jax.random.PRNGKey(0), (1000, 2), minval=-3.0, maxval=3.0) + z
  r = jax.vmap(lambda m: O.mimax_reward(O.gaussian_log_q(z, m), offset=offset))(means)
  assert float(r.min()) >= 0.0
  # sigma = 1, d = 2: r = 9 - 1/2 ||z - mean||^2 (the normaliser cancels), e.g. 9 - 0.5 * 2 = 8.
  np.testing.assert_allclose(O.mimax_reward(O.gaussian_log_q(z, z + 1.0), offset=offset), 8.0,
                             rtol=1e-5)


def test_categorical_log_q_shifts_and_clips_logits():
  logits = jnp.array([2.0, 0.0, -10.0])
  # shifted: (0, -2, -12) -> clipped at -5: (0, -2, -5); log-normaliser log(1 + e^-2 + e^-5)
  log_norm = math.log(1 + math.exp(-2) + math.exp(-5))  # 0.132840
  np.testing.assert_allclose(O.clip_logits(logits, logits_clip=5.0), [0.0, -2.0, -5.0])
  np.testing.assert_allclose(O.categorical_log_q(jnp.array([1.0, 0, 0]), logits, logits_clip=5.0),
                             -log_norm, rtol=1e-5)
  np.testing.assert_allclose(O.categorical_log_q(jnp.array([0, 0, 1.0]), logits, logits_clip=5.0),
                             -5.0 - log_norm, rtol=1e-5)
  # Shifting all logits changes nothing.
  np.testing.assert_allclose(O.categorical_log_q(jnp.array([0, 1.0, 0]), logits + 7.0),
                             O.categorical_log_q(jnp.array([0, 1.0, 0]), logits), rtol=1e-6)


def test_categorical_reward_bounds():
  # r = log q + c. Largest when z's logit is the max and all others are clipped:
  # r = c - log(1 + (K-1) e^-c) ~ c. Smallest when z's logit is clipped and all others tie at the
  # max: r = -c - log(K - 1 + e^-c) + c = -log(K - 1 + e^-c) (K = 8, c = 5: -1.9469).
  k, c = 8, 5.0
  logits = 20.0 * jax.random.normal(jax.random.PRNGKey(0), (2000, k))
  z = jax.nn.one_hot(jax.random.randint(jax.random.PRNGKey(1), (2000,), 0, k), k)
  reward = lambda z, l: O.mimax_reward(O.categorical_log_q(z, l, logits_clip=c),
                                       offset=O.categorical_offset(c))
  r = jax.vmap(reward)(z, logits)
  low, high = -math.log(k - 1 + math.exp(-c)), c - math.log(1 + (k - 1) * math.exp(-c))
  assert low - 1e-5 <= float(r.min()) and float(r.max()) <= high + 1e-5
  np.testing.assert_allclose(reward(jnp.eye(k)[0], jnp.array([-9.0] + [0.0] * 7)), low, rtol=1e-5)
  np.testing.assert_allclose(reward(jnp.eye(k)[0], jnp.array([0.0] + [-9.0] * 7)), high, rtol=1e-5)
  # A discriminator that cannot tell skills apart (equal logits) pays c - log K >= 0 for c >= log K.
  np.testing.assert_allclose(reward(jnp.eye(k)[3], jnp.zeros(k)), c - math.log(k), rtol=1e-6)


def test_priors():
  uniform = O.uniform_prior(-2.0, 3.0, 2)
  z = jax.vmap(uniform.sample)(jax.random.split(jax.random.PRNGKey(0), 500))
  assert z.shape == (500, 2) and float(z.min()) >= -2.0 and float(z.max()) <= 3.0
  np.testing.assert_allclose(uniform.log_prob(jnp.array([0.0, 1.0])), -2 * math.log(5.0),
                             rtol=1e-6)
  assert float(uniform.log_prob(jnp.array([4.0, 0.0]))) == -np.inf
  cat = O.categorical_prior(4)
  z = jax.vmap(cat.sample)(jax.random.split(jax.random.PRNGKey(1), 400))
  assert z.dtype == jnp.float32 and np.all(np.asarray(z).sum(-1) == 1.0)
  assert set(np.asarray(z).argmax(-1)) == {0, 1, 2, 3}
  np.testing.assert_allclose(cat.log_prob(jnp.array([0.0, 0, 1, 0])), -math.log(4.0), rtol=1e-6)
  det = O.deterministic_prior([5.0, 5.0])
  np.testing.assert_array_equal(det.sample(jax.random.PRNGKey(2)), [5.0, 5.0])
  assert float(det.log_prob(jnp.array([5.0, 5.0]))) == 0.0
  with pytest.raises(ValueError, match=r"num_skills must be an int in 2..65536"):
    O.categorical_prior(1)
  with pytest.raises(ValueError, match="high > low"):
    O.uniform_prior(1.0, 1.0, 2)


def test_discriminator_loss():
  # policy logits (0, 2): mean(softplus) = (0.693147 + 2.126928) / 2 = 1.410038;
  # target logit 1: softplus(-1) = 0.313262; total 1.723300.
  np.testing.assert_allclose(O.discriminator_loss(jnp.array([0.0, 2.0]), jnp.array([1.0])),
                             1.723300, rtol=1e-5)
  # Class balance: repeating policy samples does not change the loss.
  np.testing.assert_allclose(O.discriminator_loss(jnp.array([0.0, 2.0] * 5), jnp.array([1.0])),
                             1.723300, rtol=1e-5)


def test_dmin_reward_transforms():
  np.testing.assert_allclose(O.gail_reward(jnp.array(0.0)), math.log(2), rtol=1e-6)
  np.testing.assert_allclose(O.gail2_reward(jnp.array(0.0), offset=5.0), 5 - math.log(2),
                             rtol=1e-6)
  np.testing.assert_allclose(O.airl_reward(jnp.array(-1.0), offset=5.0), 4.0)
  np.testing.assert_allclose(O.fairl_reward(jnp.array(1.0), offset=5.0), 5 - math.e, rtol=1e-6)
  np.testing.assert_allclose(O.fairl_reward(jnp.array(-2.0)), 2 * math.exp(-2), rtol=1e-6)
  np.testing.assert_allclose(O.mle_reward(jnp.array(-3.0), offset=4.0), 1.0)
  # Non-negative where the paper says so: GAIL everywhere, AIRL on the clipped range [-c, c].
  logits = jnp.linspace(-5.0, 5.0, 101)
  assert float(jax.vmap(O.gail_reward)(logits).min()) >= 0.0
  assert float(jax.vmap(lambda l: O.airl_reward(l, offset=5.0))(logits).min()) >= 0.0
  # GAIL2's offset leaves at most log(1 + e^-c) below zero.
  assert float(jax.vmap(lambda l: O.gail2_reward(l, offset=5.0))(logits).min()) >= \
      -math.log(1 + math.exp(-5.0)) - 1e-6


def test_gradient_penalty_matches_finite_differences():
  w = jax.random.normal(jax.random.PRNGKey(0), (3, 4))

  def logit_fn(params, x):
    return jnp.sum(jnp.tanh(x @ params)) + 0.3 * jnp.sum(x**2)

  x_pol = jax.random.normal(jax.random.PRNGKey(1), (6, 3))
  x_tgt = jax.random.normal(jax.random.PRNGKey(2), (6, 3)) + 1.0
  key = jax.random.PRNGKey(3)
  got = O.gradient_penalty(logit_fn, w, x_pol, x_tgt, key, weight=2.0)
  # The same interpolates, the gradient by central differences in float64 numpy.
  u = np.asarray(jax.random.uniform(key, (6, 1)), np.float64)
  x_hat = u * np.asarray(x_pol, np.float64) + (1 - u) * np.asarray(x_tgt, np.float64)
  wn = np.asarray(w, np.float64)
  f = lambda x: np.sum(np.tanh(x @ wn)) + 0.3 * np.sum(x**2)
  h = 1e-5
  norms = []
  for x in x_hat:
    g = [(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(3)]
    norms.append(np.linalg.norm(g))
  np.testing.assert_allclose(got, 2.0 * np.mean(norms), rtol=1e-4)


def test_spectral_normalize_matches_svd():
  w = jax.random.normal(jax.random.PRNGKey(0), (7, 5))
  u = jax.random.normal(jax.random.PRNGKey(1), (5,))
  w_sn, u_next, sigma = O.spectral_normalize(w, u, num_iterations=100)
  top = np.linalg.svd(np.asarray(w), compute_uv=False)[0]
  np.testing.assert_allclose(sigma, top, rtol=1e-4)
  np.testing.assert_allclose(np.linalg.svd(np.asarray(w_sn), compute_uv=False)[0], 1.0, rtol=1e-4)
  assert u_next.shape == (5,)
  # One iteration at a time with the vector carried between calls converges the same way.
  for _ in range(100):
    _, u, sigma_carried = O.spectral_normalize(w, u, num_iterations=1)
  np.testing.assert_allclose(sigma_carried, top, rtol=1e-4)


def test_spectral_norm_state_persists_through_post_update():
  # A spectrally normalised discriminator: after repeated post_updates every layer's kernel
  # divided by its true top singular value equals what the network uses.
  obj = O.diayn(num_skills=4, obs_indices=(0, 1), spectral_norm=True,
                spectral_iteration="persistent")
  params = obj.init(jax.random.PRNGKey(0), 4)
  batch = O.Transition(jnp.zeros((8, 4)), jnp.zeros((8, 2)), jnp.ones((8, 4)), jnp.zeros(8),
                       jnp.tile(jnp.eye(4), (2, 1)))
  step = jax.jit(obj.post_update)
  for _ in range(200):
    params = step(params, batch)
  for name, layer in params["disc"]["params"].items():
    u = params["disc"]["spectral"][name]["u"]
    _, _, sigma = O.spectral_normalize(layer["kernel"], u, num_iterations=1)
    top = np.linalg.svd(np.asarray(layer["kernel"]), compute_uv=False)[0]
    np.testing.assert_allclose(sigma, top, rtol=1e-3, err_msg=name)


def test_spectral_norm_fixed_start_is_the_original_one_step_estimate():
  # Braxlines' default: one power iteration per call from the vector drawn at init, never advanced.
  obj = O.diayn(num_skills=4, obs_indices=(0, 1), spectral_norm=True)
  assert obj.post_update is None  # nothing to carry between SGD steps
  params = obj.init(jax.random.PRNGKey(0), 4)
  x = jnp.array([0.3, -1.2])
  # Rebuild the forward pass by hand: each layer uses W / sigma, sigma one step from the stored u.
  h = x
  layers = sorted(params["disc"]["params"])
  sigmas, tops = [], []
  for i, name in enumerate(layers):
    layer, u = params["disc"]["params"][name], params["disc"]["spectral"][name]["u"]
    w_sn, _, sigma = O.spectral_normalize(layer["kernel"], u, num_iterations=1)
    sigmas.append(float(sigma))
    tops.append(float(np.linalg.svd(np.asarray(layer["kernel"]), compute_uv=False)[0]))
    h = h @ w_sn + layer["bias"]
    if i < len(layers) - 1:
      h = jax.nn.swish(h)
  logits = obj.spec.posterior_out(params, jnp.concatenate([x, jnp.zeros(2)]))
  np.testing.assert_allclose(logits, h, rtol=1e-5, atol=1e-6)
  # A one-step estimate never exceeds the top singular value, and from a random start it falls
  # short of it: the original's constraint is looser than the exact norm.
  assert all(s <= t * (1 + 1e-5) for s, t in zip(sigmas, tops))
  assert any(s < 0.999 * t for s, t in zip(sigmas, tops))
  with pytest.raises(ValueError, match="spectral_iteration='exact'.*valid values"):
    O.diayn(num_skills=4, obs_indices=(0, 1), spectral_norm=True, spectral_iteration="exact")


def test_multimode_gaussian_layouts():
  # 1-D, scale 8, 2 modes: means at the interior of linspace(-8, 8, 4) = +-8/3, std 8/3/5.
  t1 = O.multimode_gaussian(2, scale=8.0, dim=1, num_samples=4000)
  x = np.asarray(t1.samples)[:, 0]
  np.testing.assert_allclose(np.mean(np.abs(x)), 8 / 3, rtol=0.02)
  np.testing.assert_allclose(np.std(np.abs(x)), 8 / 3 / 5, rtol=0.05)
  # 2-D, scale 8, 2 modes: means (4, 0) and (-4, 0), std 0.8 per dimension.
  t2 = O.multimode_gaussian(2, scale=8.0, dim=2, num_samples=4000)
  s = np.asarray(t2.samples)
  np.testing.assert_allclose(np.mean(np.abs(s[:, 0])), 4.0, rtol=0.02)
  np.testing.assert_allclose(np.std(s[:, 1]), 0.8, rtol=0.05)
  assert 0.45 < np.mean(s[:, 0] > 0) < 0.55
  # The density: 1/2 N((4,0); (4,0), 0.8^2 I) + 1/2 N((4,0); (-4,0), ...) ~ 1/2 / (2 pi 0.64).
  np.testing.assert_allclose(t2.log_prob(jnp.array([4.0, 0.0])),
                             math.log(0.5 / (2 * math.pi * 0.64)), rtol=1e-4)
  assert t2.samples.shape == (4000, 2) and O.multimode_gaussian(3, scale=8.0, dim=2).dim == 2
  with pytest.raises(ValueError, match="dim must be 1 or 2"):
    O.multimode_gaussian(2, scale=8.0, dim=3)


def test_target_from_samples_and_its_errors():
  t = O.target_from_samples(np.arange(10.0))
  assert t.samples.shape == (10, 1) and t.log_prob is None
  with pytest.raises(ValueError, match="NaN"):
    O.target_from_samples([[0.0, np.nan], [1.0, 2.0]])
  with pytest.raises(ValueError, match="no density"):
    O.mle(target=t, obs_indices=(0,))


@pytest.mark.parametrize("clip_loss_logits", [True, False])
def test_dmin_loss_clips_logits_like_the_original_unless_asked(clip_loss_logits):
  # A GAIL discriminator made extreme (last layer x 1000) so most logits lie far outside +-c = 5.
  target = O.target_from_samples(np.linspace(-1.0, 1.0, 8)[:, None])
  make = lambda clip: O.gail(target=target, obs_indices=(0,), balance_data=False, logits_clip=clip,
                             clip_loss_logits=clip_loss_logits)
  gail, unclipped = make(5.0), make(1e9)
  params = gail.init(jax.random.PRNGKey(1), 2)
  last = sorted(params["disc"]["params"])[-1]
  params["disc"]["params"][last] = jax.tree.map(lambda w: 1000.0 * w,
                                                params["disc"]["params"][last])
  obs = jnp.stack([jnp.linspace(-3.0, 3.0, 16), jnp.zeros(16)], -1)
  batch = O.Transition(obs, jnp.zeros((16, 1)), obs, jnp.zeros(16), jnp.zeros((16, 0)))
  value, _ = gail.loss(params, batch, jax.random.PRNGKey(0))
  raw_pol = jax.vmap(unclipped.spec.logit, (None, 0))(params, obs[:, :1])
  raw_tgt = jax.vmap(unclipped.spec.logit, (None, 0))(params, jnp.asarray(target.samples))
  assert float(jnp.max(jnp.abs(raw_pol))) > 50.0  # the clip matters for this discriminator
  l_pol, l_tgt = (jnp.clip(raw_pol, -5, 5), jnp.clip(raw_tgt, -5, 5)) if clip_loss_logits else (
      raw_pol, raw_tgt)
  # Binary cross-entropy, policy labelled 0 and target 1: mean softplus(l_pol) + mean softplus(-l_tgt).
  expected = jnp.mean(jax.nn.softplus(l_pol)) + jnp.mean(jax.nn.softplus(-l_tgt))
  np.testing.assert_allclose(value, expected, rtol=1e-5)


def test_new_objectives_compose_from_a_prior_a_posterior_and_a_reward_transform():
  # A goal-reaching objective over a 2-D box, built from the pieces rather than a preset: at the
  # goal, log N(z; z, I) = -log 2 pi and the offset is log 2 pi + 4.5 d, so r = 9; one unit off in
  # each dimension takes 1/2 ||1||^2 = 1 off.
  reach = O.mimax_objective("reach", prior=O.uniform_prior(-1.0, 1.0, 2),
                            posterior=O.identity_posterior(2), indices=(1, 2), obs_scale=2.0)
  params = reach.init(jax.random.PRNGKey(0), 4)
  z = jnp.array([0.5, -0.5])
  at_goal = O.Transition(jnp.zeros(4), jnp.zeros(1), jnp.array([7.0, 0.5, -0.5, 7.0]),
                         jnp.zeros(()), z)
  np.testing.assert_allclose(reach.reward(params, at_goal), 9.0, rtol=1e-6)
  off = at_goal._replace(next_obs=jnp.array([7.0, 1.5, 0.5, 7.0]))
  np.testing.assert_allclose(reach.reward(params, off), 8.0, rtol=1e-6)
  assert reach.loss(params, at_goal, None)[0] == 0.0  # nothing learned
  # The same categorical posterior as DIAYN's, on a 3-skill prior: an untrained network gives the
  # 3 skills nearly equal logits, so r is near the clip c minus log 3.
  class Net:  # a fixed "network": logits = the first 3 features
    has_post_update = False

    def init(self, key, n):
      return {}

    def apply(self, params, x):
      return x[:3]

    def post_update(self, params, x):
      return params

  skills = O.mimax_objective("skills", prior=O.categorical_prior(3),
                             posterior=O.categorical_posterior(3, Net(), logits_clip=5.0),
                             indices=None, obs_scale=1.0)
  t = O.Transition(jnp.zeros(3), jnp.zeros(1), jnp.zeros(3), jnp.zeros(()), jnp.eye(3)[1])
  np.testing.assert_allclose(skills.reward({}, t), 5.0 - math.log(3), rtol=1e-6)
  assert skills.spec.posterior == "categorical" and skills.spec.num_skills == 3
  # A D-min objective with a reward transform of one's own: r = 2 l.
  double = O.adversarial_objective("double", lambda l: 2.0 * l, obs_indices=(0,), obs_scale=8.0)
  dparams = double.init(jax.random.PRNGKey(0), 2)
  x = O.Transition(jnp.array([1.0, 0.0]), jnp.zeros(1), jnp.zeros(2), jnp.zeros(()), jnp.zeros(0))
  np.testing.assert_allclose(double.reward(dparams, x), 2.0 * double.spec.logit(dparams, x.obs[:1]),
                             rtol=1e-6)
