"""Every preset: shapes under jit and vmap, option errors, a few training iterations without NaN,
and two learning tests on the point mass (DIAYN skills, GAIL state-marginal matching)."""

from __future__ import annotations


import chex
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, metrics, objectives, training
from tests.conftest import make_env
from tests.training.tiny import SMALL

OBS_SIZE = 4  # the point: pos_xy (0, 1), vel_xy (2, 3)


def build(name: str, **extra):
  """Each preset with the options that exercise the most code on the point mass."""
  env = make_env("point")
  options = {
      "task": {},
      "gcrl": dict(obs_indices="pos_xy", env=env),
      "fixed_gcrl": dict(obs_indices="pos_xy", env=env, obs_scale=2.0),
      "cdiayn": dict(obs_indices="pos_xy", env=env, spectral_norm=True),
      "diayn": dict(num_skills=4, obs_indices="pos_xy", env=env, spectral_norm=True,
                    normalize_obs=True),
      "diayn_full": dict(num_skills=4),
      "gail": dict(obs_indices="pos_xy", env=env, spectral_norm=True),
      "gail2": dict(obs_indices="vel_xy", env=env, gradient_penalty_weight=1.0,
                    normalize_obs=True),
      "airl": dict(obs_indices=(0,), include_action=True,
                   target=objectives.target_from_samples(np.random.RandomState(0).randn(50, 3))),
      "fairl": dict(obs_indices="pos_xy", env=env),
      "mle": dict(obs_indices="pos_xy", env=env, obs_scale=8.0),
  }[name]
  return objectives.make(name, **{**options, **extra})


ALL = objectives.list_objectives()


def test_all_presets_are_listed_with_their_family_spec():
  mimax = {"gcrl", "fixed_gcrl", "cdiayn", "diayn", "diayn_full"}
  dmin = {"gail", "gail2", "airl", "fairl", "mle"}
  assert set(ALL) == mimax | dmin | {"task"}
  for name in ALL:
    spec_type = (objectives.MimaxSpec if name in mimax else
                 objectives.DminSpec if name in dmin else objectives.TaskSpec)
    assert isinstance(build(name).spec, spec_type), name


@pytest.mark.parametrize("name", ALL)
def test_preset_shapes_under_jit_and_vmap(name):
  obj = build(name)
  params = jax.jit(obj.init, static_argnums=1)(jax.random.PRNGKey(0), OBS_SIZE)
  n = 16
  z = jax.vmap(obj.sample_latent)(jax.random.split(jax.random.PRNGKey(1), n))
  chex.assert_shape(z, (n, obj.latent_size))
  obs = jax.random.normal(jax.random.PRNGKey(2), (n, OBS_SIZE))
  batch = objectives.Transition(obs, jnp.tanh(obs[:, :2]), obs + 0.1, jnp.ones(n), z)
  reward = jax.jit(jax.vmap(obj.reward, (None, 0)))(params, batch)
  chex.assert_shape(reward, (n,))
  chex.assert_tree_all_finite(reward)
  loss, loss_metrics = jax.jit(obj.loss)(params, batch, jax.random.PRNGKey(3))
  chex.assert_shape(loss, ())
  chex.assert_tree_all_finite((loss, loss_metrics))
  # The loss is differentiable in the objective's parameters (zero for non-learned presets).
  grads = jax.grad(lambda p: obj.loss(p, batch, jax.random.PRNGKey(3))[0])(params)
  chex.assert_trees_all_equal_shapes(grads, params)
  if obj.post_update is not None:
    chex.assert_trees_all_equal_shapes(jax.jit(obj.post_update)(params, batch), params)
  # vmap over seeds of init and of the loss.
  seeds = jax.vmap(obj.init, (0, None))(jax.random.split(jax.random.PRNGKey(4), 3), OBS_SIZE)
  losses, _ = jax.vmap(obj.loss, (0, None, None), axis_size=3)(seeds, batch, jax.random.PRNGKey(5))
  chex.assert_shape(losses, (3,))


def test_env_reward_multiplier_adds_the_task_reward():
  obj0, obj1 = build("gcrl"), build("gcrl", env_reward_multiplier=2.0)
  t = objectives.Transition(jnp.zeros(4), jnp.zeros(2), jnp.ones(4), jnp.array(3.0),
                            jnp.array([1.0, 1.0]))
  # z = s_idx: r = 4.5 * 2 = 9; plus 2 x 3.
  np.testing.assert_allclose(obj0.reward({}, t), 9.0, rtol=1e-6)
  np.testing.assert_allclose(obj1.reward({}, t), 15.0, rtol=1e-6)


def test_preset_defaults_follow_braxlines():
  diayn = objectives.diayn(obs_indices=(0, 1))
  assert diayn.latent_size == 8 and diayn.conditions_policy
  assert diayn.spec.offset == 5.0  # logits_clip 5
  gcrl = objectives.gcrl(obs_indices=(2, 3), obs_scale=5.0)
  z = jax.vmap(gcrl.sample_latent)(jax.random.split(jax.random.PRNGKey(0), 1000))
  assert float(jnp.abs(z).max()) <= 2.5  # U(-scale/2, scale/2)
  fixed = objectives.fixed_gcrl(obs_indices=(2, 3), obs_scale=5.0)
  np.testing.assert_array_equal(fixed.sample_latent(jax.random.PRNGKey(0)), [5.0, 5.0])
  gail = objectives.gail(obs_indices=(2, 3), obs_scale=8.0)
  assert gail.latent_size == 0 and not gail.conditions_policy
  np.testing.assert_allclose(np.abs(np.asarray(gail.spec.target.samples)[:, 0]).mean(), 4.0,
                             rtol=0.1)  # modes (+-4, 0)


def test_option_defaults_are_the_values_a_preset_builds_with_when_not_given():
  defaults = objectives.option_defaults("diayn")
  assert set(defaults) == set(objectives.options_of("diayn"))
  assert defaults["num_skills"] == objectives.diayn(obs_indices=(0, 1)).latent_size == 8
  assert objectives.option_defaults("gail")["gradient_penalty_weight"] == 0.0
  with pytest.raises(ValueError, match="valid objectives are"):
    objectives.option_defaults("dyain")


def test_target_seed_draws_the_default_targets_samples():
  """The seed picks which 250 samples stand for the target: seed 0 puts 131 at (+4, 0), seed 3
  puts 120 there (more at (-4, 0)); the same seed gives the same samples, for mle too."""
  def at_plus(objective):
    return int((np.asarray(objective.spec.target.samples)[:, 0] > 0).sum())
  assert at_plus(objectives.gail(obs_indices=(2, 3), obs_scale=8.0)) == 131
  assert at_plus(objectives.gail(obs_indices=(2, 3), obs_scale=8.0, target_seed=3)) == 120
  assert at_plus(objectives.mle(obs_indices=(2, 3), obs_scale=8.0, target_seed=3)) == 120
  with pytest.raises(ValueError, match="target_seed must be an int in 0..2.*, got '3'"):
    objectives.airl(obs_indices=(2, 3), target_seed="3")
  with pytest.raises(ValueError, match="target_seed=2 draws the default.*ignored"):
    objectives.gail(obs_indices=(0, 1), target_seed=2,
                    target=objectives.multimode_gaussian(2, scale=4, dim=2))


def test_option_errors_name_the_problem():
  with pytest.raises(ValueError, match="unknown objective 'dayn'.*'diayn'"):
    objectives.make("dayn")
  with pytest.raises(ValueError, match="unknown option.*'num_skill'.*valid options"):
    objectives.make("diayn", num_skill=4, obs_indices=(0,))
  with pytest.raises(ValueError, match="pass env="):
    objectives.diayn(obs_indices="vel_xy")
  with pytest.raises(ValueError, match="give obs_indices.*diayn_full"):
    objectives.diayn()
  with pytest.raises(ValueError, match="out of range"):
    objectives.gcrl(obs_indices=(0, 9)).init(jax.random.PRNGKey(0), 4)
  with pytest.raises(ValueError, match="needs balance_data"):
    objectives.gail(obs_indices=(0,), gradient_penalty_weight=1.0, balance_data=False)
  with pytest.raises(ValueError, match="dimension 2 but obs_indices has 1"):
    objectives.gail(obs_indices=(0,), target=objectives.multimode_gaussian(2, scale=4, dim=2))
  with pytest.raises(ValueError, match="unknown option.*'spectral_norm'"):
    objectives.make("gcrl", obs_indices=(0,), spectral_norm=True)  # gcrl learns nothing
  with pytest.raises(ValueError, match="logits_clip must be > 0"):
    objectives.diayn(obs_indices=(0,), logits_clip=0.0)


@pytest.mark.parametrize("name", ALL)
def test_every_preset_trains_on_point_without_nan(name):
  obj = build(name)
  env = envs.episode(envs.unwrap(make_env("point")), 20)  # the episodes SMALL is sized for
  result = training.train(env, obj, SMALL, seeds=(0,), progress=False)
  chex.assert_tree_all_finite(result.params)
  last = result.metrics[-1]
  assert np.isfinite(last["loss/total"]).all() and np.isfinite(last["eval/episode_reward"]).all()
  if not isinstance(obj.spec, objectives.TaskSpec) and obj.init(jax.random.PRNGKey(0), 4):
    # Learned discriminators moved away from their initialisation.
    init = obj.init(jax.random.PRNGKey(0), 4)
    trained = jax.tree.map(lambda x: x[0], result.params.objective)
    assert not all(np.allclose(a, b) for a, b in
                   zip(jax.tree.leaves(init["disc"]["params"]),
                       jax.tree.leaves(trained["disc"]["params"])))


def _skill_accuracy_fn(env, obj, policy, *, episodes=8):
  """A jitted ``params -> (accuracy, places [K, 2])`` for one seed's ``params``: the fraction of the
  second half of fresh deterministic episodes whose state the discriminator assigns to the skill
  that produced it, and each skill's mean place there. One program for every seed (run op by op,
  each call compiled its rollout and some 700 single operations again)."""
  k = obj.latent_size
  infer = obj.spec.infer_latent

  @jax.jit
  def accuracy(params):
    states = metrics.rollout(env, policy, params, jnp.eye(k), jax.random.PRNGKey(123),
                             episodes_per_latent=episodes, deterministic=True)
    late = states[:, :, states.shape[2] // 2:]  # the second half of the point's 50-step episodes
    predicted = jax.vmap(jax.vmap(jax.vmap(lambda o: infer(params.objective, o))))(late)
    return ((predicted.argmax(-1) == jnp.arange(k)[:, None, None]).mean(),
            late[..., :2].mean((1, 2)))

  return lambda params: tuple(np.asarray(x) for x in accuracy(params))


@pytest.mark.run_bound
def test_diayn_learns_four_distinguishable_skills_on_point():
  env = make_env("point")
  # The paper's MI-max setting (spectral norm on). With Braxlines' PPO (no advantage normalisation,
  # z normalised with the observation) an entropy cost of 1e-2 keeps the skills exploring long
  # enough to spread: seeds 0, 1, 2 end with accuracy 1.0, 1.0, 0.93 and skills 5.1, 3.1, 2.6 m
  # apart.
  obj = objectives.diayn(num_skills=4, obs_indices="pos_xy", env=env, spectral_norm=True)
  config = training.ppo_defaults("point", num_timesteps=150_000, entropy_cost=1e-2)
  trainer = training.make_trainer(env, obj, config)
  skill_accuracy = _skill_accuracy_fn(env, obj, trainer.policy)
  before, _ = skill_accuracy(training.policy_params(jax.jit(trainer.init)(jax.random.PRNGKey(0))))
  seeds = (0, 1, 2)  # vmapped in one program: on a CPU, about the cost of one
  result = training.train(env, obj, config, seeds=seeds, progress=False)
  after = [skill_accuracy(jax.tree.map(lambda x: x[i], result.params)) for i in range(len(seeds))]
  # Baseline: an untrained policy and discriminator classify at about chance (1/4); trained skills
  # end in different places, which the discriminator tells apart. One seed's accuracy depends on
  # the CPU's floating-point rounding: where this test was written seed 0 alone gave 0.86 to 1.0;
  # on another 2-core CPU (session 15) seeds 0, 1, 2 gave 0.75, 0.81, 0.78 (the discriminator
  # loses one skill once it is far out); on a 2-core AMD EPYC (session 23) seed 0 alone gave 0.5
  # with its four skills 2.2-13 m apart, and the three seeds vmapped gave 1.0, 1.0, 0.57, as they
  # did at XLA's default optimisation (session 82, ``run_bound``). So the test asks it of the
  # median seed: 0.7 means at least three of the four skills are told apart.
  assert before < 0.6, before
  accuracies = [float(a) for a, _ in after]
  assert sorted(accuracies)[1] > 0.7, after
  for _, places in after:  # every seed's skills end in visibly different places
    distances = np.linalg.norm(places[:, None] - places[None], axis=-1)
    assert distances[np.triu_indices(4, 1)].min() > 1.0, places


@pytest.mark.run_bound
def test_gail_moves_the_state_distribution_toward_a_bimodal_target():
  env = make_env("point")
  # Two modes at (4, +-1.5), std 0.4: the point starts at the origin, far from both.
  rng = np.random.RandomState(0)
  modes = np.array([[4.0, 1.5], [4.0, -1.5]])
  samples = modes[rng.randint(0, 2, 250)] + 0.4 * rng.randn(250, 2)
  obj = objectives.gail(target=objectives.target_from_samples(samples), obs_indices="pos_xy",
                        env=env)
  config = training.ppo_defaults("point", num_timesteps=600_000)
  evaluate = metrics.dmin_evaluator(env, obj, num_episodes=4, last_steps=25, every=1)
  seeds = (0, 1, 2)  # vmapped in one program
  result = training.train(env, obj, config, seeds=seeds, progress=False, evaluate=evaluate)
  after = sorted(float(a) for a in result.metrics[-1]["eval/energy_distance"])
  # Baseline: a point that stays at its start, the origin, far from both modes (energy distance
  # 6.7). An untrained policy's sampled actions make it wander (8.6, 6.7 and 1.8 for seeds 0-2:
  # seed 2's happens to drift toward the modes), so the baseline is the origin, not the untrained
  # seed. Matching must at least halve it. One seed's outcome depends on the CPU's floating-point
  # rounding: on a 2-core AMD EPYC with AVX-512 (session 39) seed 0 alone ended at 6.7 under the
  # tests' fast-compile XLA flags and below half under the default ones, from the same untrained
  # policy; the three seeds vmapped ended at 0.63, 18.0 (run off) and 1.51, and at XLA's default
  # optimisation (session 82, ``run_bound``) at 0.83, 1.59 and 17.3. So, as for DIAYN above, the
  # test asks it of the median seed. On a 2-core Intel Xeon with AVX-512 (session 90) the three
  # seeds at 300 k steps ended at 4.59, 16.9 and 1.09: seed 0 had been at 1.54 at 154 k and left
  # it again (GAIL's discriminator keeps moving its reward), so the median missed half (3.35). Over
  # 600 k steps they pass through 1.51, 7.0 and 0.71 at 453 k and end at 1.44, 16.8 and 1.09: the
  # test trains 600 k, where the median seed has settled, not mid-swing.
  still = float(metrics.energy_distance(jnp.zeros((100, 2)), jnp.asarray(samples)))
  assert still > 5.0, still
  assert after[1] < 0.5 * still, (still, after)
