"""The Braxlines presets (paper Table 1), each a function returning an ``Objective``.

MI-max (variational empowerment, reward r = log q(z|s') + offset):

| preset       | z                | p(z)                               | q(z|s)                      | learned |
| ------------ | ---------------- | ---------------------------------- | --------------------------- | ------- |
| fixed_gcrl   | d = #indices     | z = obs_scale in every dimension   | N(s_idx, I)                 | no      |
| gcrl         | d                | U(-obs_scale/2, obs_scale/2)^d     | N(s_idx, I)                 | no      |
| cdiayn       | d                | U(-1, 1)^d                         | N(MLP(s_idx), I)            | yes     |
| diayn        | K one-hot        | uniform over K                     | Cat(MLP(s_idx))             | yes     |
| diayn_full   | K one-hot        | uniform over K                     | Cat(MLP(s)), full obs       | yes     |

D-min (state-marginal matching to a target p*(s), reward from the clipped logit l of the pre-step
state): ``gail`` softplus(l), ``gail2`` log sigmoid(l) + c, ``airl`` l + c, ``fairl`` -l e^l + c, and
``mle`` log p*(s) + offset (an oracle for a known density). ``task`` maximises the env's reward.

Every preset takes keyword-only options; ``make(name, **options)`` builds one by name. Observation
indices may be ints or names such as ``"vel_xy"``; names are resolved through ``env=`` (anything with
an ``obs_indices(name)`` method, e.g. a ``blx.envs.Env``), so this module never imports the envs.
"""

from __future__ import annotations

import inspect
import itertools
from typing import Any, Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from blx import running_stats
from blx.objectives import dmin, mimax, posteriors, priors, spectral
from blx.objectives.base import Objective, Transition, task
from blx.objectives.posteriors import Posterior
from blx.objectives.specs import DminSpec, MimaxSpec
from blx.objectives.targets import Target, multimode_gaussian
from blx.options import check_names, keyword_names

__all__ = ["gcrl", "fixed_gcrl", "cdiayn", "diayn", "diayn_full", "gail", "gail2", "airl", "fairl",
           "mle", "task", "make", "list_objectives", "options_of", "option_defaults",
           "resolve_indices", "mimax_objective", "adversarial_objective"]

Indices = Sequence[int] | str | Sequence[str] | None


# ------------------------------------------------------------------------------------------------
# Shared pieces


def resolve_indices(obs_indices: Indices, env: Any = None, *, who: str) -> tuple[int, ...] | None:
  """Ints as they are; names (``"vel_xy"`` or a list of names) through ``env.obs_indices``."""
  if obs_indices is None:
    return None
  if isinstance(obs_indices, (int, np.integer)) and not isinstance(obs_indices, bool):
    obs_indices = [obs_indices]
  if not isinstance(obs_indices, (str, list, tuple, np.ndarray)):
    raise ValueError(f"{who}: obs_indices must be a name such as 'vel_xy', an int or a list of "
                     f"them, got {obs_indices!r}")
  names = [obs_indices] if isinstance(obs_indices, str) else list(obs_indices)
  if not names:
    raise ValueError(f"{who}: obs_indices is empty")
  out: list[int] = []
  for item in names:
    if isinstance(item, str):
      if env is None or not hasattr(env, "obs_indices"):
        raise ValueError(f"{who}: obs_indices={item!r} is a name; pass env= to resolve it "
                         "(or give ints, e.g. env.obs_indices('vel_xy'))")
      out.extend(int(i) for i in env.obs_indices(item))
    elif isinstance(item, (int, np.integer)) and not isinstance(item, bool) and item >= 0:
      out.append(int(item))
    else:
      raise ValueError(f"{who}: obs_indices must be non-negative ints or names, got {item!r}")
  repeated = sorted({i for i in out if out.count(i) > 1})
  if repeated:
    raise ValueError(f"{who}: obs_indices {out} repeat {repeated}; each observation dimension is "
                     "one feature, so indices are distinct")
  return tuple(out)


def _check_indices(indices, obs_size: int, who: str) -> None:
  if indices is not None and max(indices) >= obs_size:
    raise ValueError(f"{who}: obs_indices {list(indices)} out of range for an observation of size "
                     f"{obs_size}")


def _select(obs: jax.Array, indices) -> jax.Array:
  return obs if indices is None else obs[np.asarray(indices)]


def _check_types(who: str, *, numbers: dict | None = None, flags: dict | None = None,
                 hidden=None) -> None:
  """Options of the wrong type fail here, by name (a string "True" would otherwise be truthy)."""
  for name, value in (numbers or {}).items():
    if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
      raise ValueError(f"{who}: {name} must be a number, got {value!r}")
    if not np.isfinite(value):
      raise ValueError(f"{who}: {name} must be finite, got {value!r}")
  for name, value in (flags or {}).items():
    if not isinstance(value, bool):
      raise ValueError(f"{who}: {name} must be True or False, got {value!r}")
  if hidden is not None and (not isinstance(hidden, (tuple, list)) or not all(
      isinstance(h, int) and not isinstance(h, bool) and h > 0 for h in hidden)):
    raise ValueError(f"{who}: hidden must be a sequence of positive ints, e.g. (32, 32), got "
                     f"{hidden!r}")


SPECTRAL_ITERATIONS = ("fixed", "persistent")


def _check_spectral(who: str, spectral_iteration: Any) -> None:
  if spectral_iteration not in SPECTRAL_ITERATIONS:
    raise ValueError(f"{who}: spectral_iteration={spectral_iteration!r} is not valid; valid values "
                     f"are {list(SPECTRAL_ITERATIONS)}")


def _check_options(who: str, **given: Any) -> None:
  """The given options (``logits_clip``, ``obs_scale``) must be numbers > 0 (None is not one)."""
  _check_types(who, numbers=given)
  for name, value in given.items():
    if not value > 0:
      raise ValueError(f"{who}: {name} must be > 0, got {value}")


class _Disc:
  """A discriminator network with optional spectral norm and input normalisation (pure helpers).

  ``spectral_iteration``: "fixed" (Braxlines) runs one power iteration per call from the start
  vector drawn at init, so sigma(W) is a loose, one-step estimate; "persistent" carries the vector
  across SGD steps (``post_update``), so the estimate converges to the exact largest singular value.
  """

  def __init__(self, out: int, hidden: Sequence[int], spectral_norm: bool, normalize_obs: bool,
               spectral_iteration: str = "fixed"):
    self.net = spectral.DiscriminatorMLP(out=out, hidden=tuple(hidden),
                                         spectral_norm=spectral_norm)
    self.spectral_norm = spectral_norm
    self.persistent = spectral_norm and spectral_iteration == "persistent"
    self.normalize_obs = normalize_obs

  @property
  def has_post_update(self) -> bool:
    return self.persistent or self.normalize_obs

  def init(self, key: jax.Array, in_size: int) -> dict:
    params = {"disc": dict(self.net.init(key, jnp.zeros((in_size,))))}
    if self.normalize_obs:
      params["obs_stats"] = running_stats.init_stats(in_size)
    return params

  def apply(self, params: dict, x: jax.Array) -> jax.Array:
    if self.normalize_obs:
      x = running_stats.normalize(jax.lax.stop_gradient(params["obs_stats"]), x)
    return self.net.apply(params["disc"], x)

  def post_update(self, params: dict, x_batch: jax.Array) -> dict:
    """Advances the spectral-norm vectors one power iteration; merges x_batch into the stats."""
    params = dict(params)
    if self.persistent:
      variables = params["disc"]
      _, updates = self.net.apply(variables, jnp.zeros(x_batch.shape[-1:]), update_stats=True,
                                  mutable=["spectral"])
      params["disc"] = {**variables, "spectral": updates["spectral"]}
    if self.normalize_obs:
      params["obs_stats"] = running_stats.update_stats(params["obs_stats"], x_batch)
    return params


# ------------------------------------------------------------------------------------------------
# MI-max


def mimax_objective(name: str, *, prior: priors.Prior, posterior: Posterior,
                    indices: tuple[int, ...] | None, obs_scale: float,
                    env_reward_multiplier: float = 0.0, eval_indices=None) -> Objective:
  """Composes an MI-max objective from a prior p(z) and a posterior q(z | s[indices]).

  The reward is r = log q(z | s') + ``posterior.offset`` (+ ``env_reward_multiplier`` x the env's
  reward); a learned posterior is trained to maximise log q on the policy's transitions.
  ``indices``: the observation dimensions q reads (None: all); ``eval_indices``: those evaluation
  looks at (default ``indices``); ``obs_scale``: the half-width of evaluation's histograms.
  """
  if not isinstance(posterior, Posterior):
    raise ValueError(f"{name}: posterior must be a blx.objectives.Posterior (e.g. "
                     f"identity_posterior(d)), got {type(posterior).__name__}")
  _check_types(name, numbers=dict(env_reward_multiplier=env_reward_multiplier))
  _check_options(name, obs_scale=obs_scale)
  network = posterior.network

  def init(key, obs_size):
    _check_indices(indices, obs_size, name)
    return posterior.init(key, obs_size if indices is None else len(indices))

  def posterior_out(params, obs):
    """The posterior's output for one observation: the Gaussian mean or the logits ``[Z]``."""
    return posterior.out(params, _select(obs, indices))

  def log_q(params, obs, z):
    return posterior.log_q(z, posterior_out(params, obs))

  def reward(params, t: Transition):
    r = mimax.mimax_reward(log_q(params, t.next_obs, t.z), offset=posterior.offset)
    return r + env_reward_multiplier * t.env_reward

  def loss(params, batch: Transition, key):
    del key
    if network is None:
      return jnp.zeros(()), {}
    out = jax.vmap(posterior_out, (None, 0))(params, batch.next_obs)
    lq = jax.vmap(posterior.log_q)(batch.z, out)
    value = -jnp.mean(lq)
    metrics = {"loss/disc": value, "disc/log_q": jnp.mean(lq)}
    if posterior.accuracy is not None:
      metrics["disc/accuracy"] = posterior.accuracy(out, batch.z)
    return value, metrics

  def post_update(params, batch: Transition):
    return network.post_update(params, jax.vmap(lambda o: _select(o, indices))(batch.next_obs))

  def infer_latent(params, obs):
    """The skill that best explains ``obs``: the posterior mean, or the one-hot argmax."""
    return posterior.infer(posterior_out(params, obs))

  return Objective(
      init=init, sample_latent=prior.sample, reward=reward, loss=loss, latent_size=prior.dim,
      conditions_policy=True, name=name,
      post_update=post_update if network is not None and network.has_post_update else None,
      spec=MimaxSpec(prior=prior, obs_indices=indices,
                     eval_indices=eval_indices if eval_indices is not None else indices,
                     obs_scale=float(obs_scale), offset=posterior.offset, posterior=posterior.kind,
                     posterior_out=posterior_out, infer_latent=infer_latent, log_q=log_q))


def _learned(name: str, dim: int, *, logits_clip: float, spectral_norm: bool,
             normalize_obs: bool, hidden: Sequence[int], spectral_iteration: str) -> _Disc:
  """The checked discriminator network of a learned posterior (``mimax_objective`` checks the
  rest)."""
  _check_options(name, logits_clip=logits_clip)
  _check_types(name, flags=dict(spectral_norm=spectral_norm, normalize_obs=normalize_obs),
               hidden=hidden)
  _check_spectral(name, spectral_iteration)
  return _Disc(dim, hidden, spectral_norm, normalize_obs, spectral_iteration)


def _goal(name: str, prior: priors.Prior, indices, obs_scale: float,
          env_reward_multiplier: float) -> Objective:
  """GCRL-style: the features are the goal, q(z | s) = N(s_idx, I)."""
  _check_options(name, obs_scale=obs_scale)
  if len(indices) != prior.dim:
    raise ValueError(f"{name}: {len(indices)} obs_indices for a {prior.dim}-D latent")
  return mimax_objective(name, prior=prior, posterior=posteriors.identity_posterior(prior.dim),
                         indices=indices, obs_scale=obs_scale,
                         env_reward_multiplier=env_reward_multiplier)


def _need_indices(name, obs_indices, env):
  indices = resolve_indices(obs_indices, env, who=name)
  if indices is None:
    hint = "; or use diayn_full for the full observation" if "diayn" in name else ""
    raise ValueError(f"{name}: give obs_indices (ints or a name such as 'vel_xy' with env=){hint}")
  return indices


def fixed_gcrl(*, obs_indices: Indices = None, env: Any = None, obs_scale: float = 5.0,
               env_reward_multiplier: float = 0.0) -> Objective:
  """Goal-conditioned RL to one fixed goal z = obs_scale in every indexed dimension;
  r = 4.5 d - 1/2 ||z - s_idx||^2 + const normaliser terms (>= 0 within 3 of the goal)."""
  indices = _need_indices("fixed_gcrl", obs_indices, env)
  _check_options("fixed_gcrl", obs_scale=obs_scale)  # used before mimax_objective
  return _goal("fixed_gcrl", priors.deterministic_prior(np.full(len(indices), obs_scale)),
               indices, obs_scale, env_reward_multiplier)


def gcrl(*, obs_indices: Indices = None, env: Any = None, obs_scale: float = 5.0,
         env_reward_multiplier: float = 0.0) -> Objective:
  """Goal-conditioned RL: z ~ U(-obs_scale/2, obs_scale/2)^d, q(z|s) = N(s_idx, I)."""
  indices = _need_indices("gcrl", obs_indices, env)
  _check_options("gcrl", obs_scale=obs_scale)  # used before mimax_objective
  half = 0.5 * obs_scale
  return _goal("gcrl", priors.uniform_prior(-half, half, len(indices)), indices, obs_scale,
               env_reward_multiplier)


def cdiayn(*, obs_indices: Indices = None, env: Any = None, obs_scale: float = 5.0,
           spectral_norm: bool = False, env_reward_multiplier: float = 0.0,
           normalize_obs: bool = False, hidden: Sequence[int] = (32, 32),
           spectral_iteration: str = "fixed") -> Objective:
  """Continuous DIAYN: z ~ U(-1, 1)^d, q(z|s) = N(MLP(s_idx), I) with a learned MLP."""
  indices = _need_indices("cdiayn", obs_indices, env)
  dim = len(indices)
  network = _learned("cdiayn", dim, logits_clip=5.0,
                     spectral_norm=spectral_norm, normalize_obs=normalize_obs, hidden=hidden,
                     spectral_iteration=spectral_iteration)
  return mimax_objective("cdiayn", prior=priors.uniform_prior(-1.0, 1.0, dim),
                         posterior=posteriors.gaussian_posterior(dim, network), indices=indices,
                         obs_scale=obs_scale, env_reward_multiplier=env_reward_multiplier)


def _skills(name: str, num_skills: int, indices, *, obs_scale, logits_clip, spectral_norm,
            env_reward_multiplier, normalize_obs, hidden, spectral_iteration,
            eval_indices=None) -> Objective:
  """DIAYN-style: K one-hot skills and a learned categorical posterior."""
  prior = priors.categorical_prior(num_skills)
  network = _learned(name, prior.dim, logits_clip=logits_clip,
                     spectral_norm=spectral_norm, normalize_obs=normalize_obs, hidden=hidden,
                     spectral_iteration=spectral_iteration)
  return mimax_objective(name, prior=prior,
                         posterior=posteriors.categorical_posterior(prior.dim, network,
                                                                    logits_clip),
                         indices=indices, obs_scale=obs_scale,
                         env_reward_multiplier=env_reward_multiplier, eval_indices=eval_indices)


def diayn(*, num_skills: int = 8, obs_indices: Indices = None, env: Any = None,
          obs_scale: float = 5.0, logits_clip: float = 5.0, spectral_norm: bool = False,
          env_reward_multiplier: float = 0.0, normalize_obs: bool = False,
          hidden: Sequence[int] = (32, 32), spectral_iteration: str = "fixed") -> Objective:
  """DIAYN (Eysenbach et al. 2019): K one-hot skills, q(z|s) = Cat(MLP(s_idx)) on chosen features;
  r = log softmax(clip(l - max l, -c))[z] + c, which is c - log K for an undecided discriminator."""
  indices = _need_indices("diayn", obs_indices, env)
  return _skills("diayn", num_skills, indices, obs_scale=obs_scale, logits_clip=logits_clip,
                 spectral_norm=spectral_norm, env_reward_multiplier=env_reward_multiplier,
                 normalize_obs=normalize_obs, hidden=hidden,
                 spectral_iteration=spectral_iteration)


def diayn_full(*, num_skills: int = 8, obs_scale: float = 5.0, logits_clip: float = 5.0,
               spectral_norm: bool = False, env_reward_multiplier: float = 0.0,
               normalize_obs: bool = False, hidden: Sequence[int] = (32, 32),
               obs_indices: Indices = None, env: Any = None,
               spectral_iteration: str = "fixed") -> Objective:
  """DIAYN on the full observation (no feature engineering): q(z|s) = Cat(MLP(s)).

  ``obs_indices`` does not restrict the discriminator here; it only names the dimensions that
  evaluation (MI, LGR) and plots look at, as in the paper.
  """
  indices = resolve_indices(obs_indices, env, who="diayn_full")
  return _skills("diayn_full", num_skills, None, obs_scale=obs_scale, logits_clip=logits_clip,
                 spectral_norm=spectral_norm, env_reward_multiplier=env_reward_multiplier,
                 normalize_obs=normalize_obs, hidden=hidden,
                 spectral_iteration=spectral_iteration, eval_indices=indices)


# ------------------------------------------------------------------------------------------------
# D-min


def _default_target(name, target, indices, obs_scale, num_modes, target_seed) -> Target:
  if isinstance(target_seed, bool) or not isinstance(target_seed, (int, np.integer)) \
      or not 0 <= target_seed <= 2**31 - 1:
    raise ValueError(f"{name}: target_seed must be an int in 0..2**31 - 1, got {target_seed!r}")
  if target is None:
    if len(indices) not in (1, 2):
      raise ValueError(f"{name}: the default target is a {num_modes}-mode Gaussian in 1 or 2 "
                       f"dimensions, but obs_indices has {len(indices)}; pass target=")
    return multimode_gaussian(num_modes, scale=obs_scale, dim=len(indices), seed=int(target_seed))
  if not isinstance(target, Target):
    raise ValueError(f"{name}: target must be a blx.objectives.Target (multimode_gaussian(...) or "
                     f"target_from_samples(...)), got {type(target).__name__}")
  if target_seed != 0:
    raise ValueError(f"{name}: target_seed={target_seed!r} draws the default target's samples; "
                     "with target= given it would be ignored, so give one or the other")
  return target


def _matched(name: str, *, target, obs_indices, env, obs_scale: float, num_modes: int,
             include_action: bool, target_seed: int = 0):
  """What every D-min objective shares: the matched features, the target, and ``disc_input(obs,
  action) -> x``, the features (plus the action when ``include_action``)."""
  indices = resolve_indices(obs_indices, env, who=name)
  if indices is None:
    raise ValueError(f"{name}: give obs_indices (ints or a name such as 'vel_xy' with env=)")
  _check_types(name, flags=dict(include_action=include_action))
  _check_options(name, obs_scale=obs_scale)
  target = _default_target(name, target, indices, obs_scale, num_modes, target_seed)
  if not include_action and target.dim != len(indices):
    raise ValueError(f"{name}: target samples have dimension {target.dim} but obs_indices has "
                     f"{len(indices)}")

  def disc_input(obs, action):
    x = _select(obs, indices)
    return jnp.concatenate([x, action]) if include_action else x

  return indices, target, disc_input


def adversarial_objective(name: str, transform: Callable[[jax.Array], jax.Array], *,
                          target: Target | None = None, obs_indices: Indices = None,
                          env: Any = None, obs_scale: float = 5.0, num_modes: int = 2,
                          include_action: bool = False, logits_clip: float = 5.0,
                          spectral_norm: bool = False, gradient_penalty_weight: float = 0.0,
                          env_reward_multiplier: float = 0.0, normalize_obs: bool = False,
                          balance_data: bool = True, hidden: Sequence[int] = (32, 32),
                          clip_loss_logits: bool = True,
                          spectral_iteration: str = "fixed", target_seed: int = 0) -> Objective:
  """Composes a D-min objective from a discriminator D(x) = sigmoid(l), trained to tell target
  samples (label 1) from the policy's (label 0), and a reward ``transform(l)`` of its clipped logit
  (``gail`` uses ``blx.objectives.gail_reward``). The options are ``gail``'s."""
  indices, target, disc_input = _matched(name, target=target, obs_indices=obs_indices, env=env,
                                         obs_scale=obs_scale, num_modes=num_modes,
                                         include_action=include_action, target_seed=target_seed)
  _check_options(name, logits_clip=logits_clip)  # obs_scale: checked in _matched
  _check_types(name, numbers=dict(env_reward_multiplier=env_reward_multiplier,
                                  gradient_penalty_weight=gradient_penalty_weight),
               flags=dict(spectral_norm=spectral_norm, normalize_obs=normalize_obs,
                          balance_data=balance_data, clip_loss_logits=clip_loss_logits),
               hidden=hidden)
  _check_spectral(name, spectral_iteration)
  if gradient_penalty_weight < 0:
    raise ValueError(f"{name}: gradient_penalty_weight must be >= 0, got {gradient_penalty_weight}")
  if gradient_penalty_weight > 0 and not balance_data:
    raise ValueError(f"{name}: gradient_penalty_weight > 0 interpolates policy and target samples "
                     "pairwise and needs balance_data=True")
  target_samples = jnp.asarray(target.samples, jnp.float32)
  disc = _Disc(1, hidden, spectral_norm, normalize_obs, spectral_iteration)

  def raw_logit(params, x):
    return disc.apply(params, x)[0]

  def logit(params, x):
    """The clipped discriminator logit of one input ``x [D]``: D(x) = sigmoid(logit)."""
    return jnp.clip(raw_logit(params, x), -logits_clip, logits_clip)

  def init(key, obs_size):
    _check_indices(indices, obs_size, name)
    return disc.init(key, target.dim)

  def reward(params, t: Transition):
    x = disc_input(t.obs, t.action)
    if x.shape != target_samples.shape[1:]:
      raise ValueError(f"{name}: the discriminator input has size {x.shape[0]} but the target "
                       f"samples have {target.dim} (include_action adds the action size)")
    return transform(logit(params, x)) + env_reward_multiplier * t.env_reward

  def loss(params, batch: Transition, key):
    x_policy = jax.vmap(disc_input)(batch.obs, batch.action)
    x_target = target_samples
    policy_key, target_key, gp_key = jax.random.split(key, 3)
    if balance_data:
      m = min(x_policy.shape[0], x_target.shape[0])
      x_policy = x_policy[jax.random.choice(policy_key, x_policy.shape[0], (m,), replace=False)]
      x_target = x_target[jax.random.choice(target_key, x_target.shape[0], (m,), replace=False)]
    # Braxlines clips the logit inside its Bernoulli, so the loss has no gradient where |l| > c.
    # clip_loss_logits=False trains on the raw logit instead (the clip then bounds the reward only),
    # so states whose logit extrapolates past +-c can still be corrected.
    loss_logit = logit if clip_loss_logits else raw_logit
    logits_policy = jax.vmap(loss_logit, (None, 0))(params, x_policy)
    logits_target = jax.vmap(loss_logit, (None, 0))(params, x_target)
    value = dmin.discriminator_loss(logits_policy, logits_target)
    metrics = {"loss/disc": value,
               "disc/policy_prob": jnp.mean(jax.nn.sigmoid(logits_policy)),
               "disc/target_prob": jnp.mean(jax.nn.sigmoid(logits_target))}
    if gradient_penalty_weight > 0:
      penalty = dmin.gradient_penalty(raw_logit, params, x_policy, x_target, gp_key,
                                      weight=gradient_penalty_weight)
      metrics["loss/gradient_penalty"] = penalty
      value = value + penalty
    return value, metrics

  def post_update(params, batch: Transition):
    return disc.post_update(params, jax.vmap(disc_input)(batch.obs, batch.action))

  return Objective(
      init=init, sample_latent=lambda key: jnp.zeros((0,)), reward=reward, loss=loss,
      latent_size=0, conditions_policy=False, name=name,
      post_update=post_update if disc.has_post_update else None,
      spec=DminSpec(obs_indices=indices, obs_scale=float(obs_scale), target=target,
                    include_action=include_action, logit=logit))


def mle(*, target: Target | None = None, obs_indices: Indices = None, env: Any = None,
        obs_scale: float = 5.0, num_modes: int = 2, env_reward_multiplier: float = 0.0,
        target_seed: int = 0) -> Objective:
  """MLE (oracle): r = log p*(s) + offset for a target with a density; nothing is learned.

  The offset is -min log p* over the grid {-1, 0, 1}^d * obs_scale and the target samples
  (Braxlines). Options as for ``gail`` where they apply: ``target``, ``obs_indices`` (with
  ``env=``), ``obs_scale``, ``num_modes``, ``env_reward_multiplier``, ``target_seed``.
  """
  indices, target, disc_input = _matched("mle", target=target, obs_indices=obs_indices, env=env,
                                         obs_scale=obs_scale, num_modes=num_modes,
                                         include_action=False, target_seed=target_seed)
  _check_types("mle", numbers=dict(env_reward_multiplier=env_reward_multiplier))
  offset = _mle_offset(target, len(indices), obs_scale)

  def init(key, obs_size):
    _check_indices(indices, obs_size, "mle")
    return {}

  def reward(params, t: Transition):
    log_p = target.log_prob(disc_input(t.obs, t.action))
    return dmin.mle_reward(log_p, offset=offset) + env_reward_multiplier * t.env_reward

  return Objective(
      init=init, sample_latent=lambda key: jnp.zeros((0,)), reward=reward,
      loss=lambda params, batch, key: (jnp.zeros(()), {}), latent_size=0, conditions_policy=False,
      name="mle", post_update=None,
      spec=DminSpec(obs_indices=indices, obs_scale=float(obs_scale), target=target,
                    include_action=False, logit=None))


def _mle_offset(target: Target, dim: int, obs_scale: float) -> float:
  """-min log p* over the grid {-1, 0, 1}^d * obs_scale and the target samples (Braxlines)."""
  if target.log_prob is None:
    raise ValueError("mle: the target has no density (target_from_samples); use multimode_gaussian "
                     "or a learned D-min objective such as gail")
  grid = np.array(list(itertools.product((-1.0, 0.0, 1.0), repeat=dim)), np.float32) * obs_scale
  points = jnp.concatenate([jnp.asarray(grid), jnp.asarray(target.samples, jnp.float32)])
  return float(-jnp.min(jax.vmap(target.log_prob)(points)))


def _dmin_preset(name: str, transform_factory: Callable[[float], Callable],
                 doc: str) -> Callable[..., Objective]:
  def preset(*, target: Target | None = None, obs_indices: Indices = None, env: Any = None,
             obs_scale: float = 5.0, num_modes: int = 2, include_action: bool = False,
             logits_clip: float = 5.0, spectral_norm: bool = False,
             gradient_penalty_weight: float = 0.0, env_reward_multiplier: float = 0.0,
             normalize_obs: bool = False, balance_data: bool = True,
             hidden: Sequence[int] = (32, 32), clip_loss_logits: bool = True,
             spectral_iteration: str = "fixed", target_seed: int = 0) -> Objective:
    return adversarial_objective(name, transform_factory(logits_clip), target=target,
                        obs_indices=obs_indices, env=env, obs_scale=obs_scale,
                        num_modes=num_modes, include_action=include_action,
                        logits_clip=logits_clip, spectral_norm=spectral_norm,
                        gradient_penalty_weight=gradient_penalty_weight,
                        env_reward_multiplier=env_reward_multiplier,
                        normalize_obs=normalize_obs, balance_data=balance_data, hidden=hidden,
                        clip_loss_logits=clip_loss_logits,
                        spectral_iteration=spectral_iteration, target_seed=target_seed)

  preset.__name__ = preset.__qualname__ = name
  preset.__doc__ = doc + """

  Options: ``target`` (default: ``multimode_gaussian(num_modes, scale=obs_scale, dim=len(idx))``),
  ``obs_indices`` (ints, or names with ``env=``), ``include_action`` (the discriminator also sees
  a_t; the target samples must then hold [s_idx, a]), ``logits_clip`` c, ``spectral_norm``,
  ``gradient_penalty_weight``, ``env_reward_multiplier``, ``normalize_obs`` (running statistics of
  the discriminator input), ``balance_data`` (subsample both sets to the smaller size),
  ``clip_loss_logits`` (default True, Braxlines: the loss sees the logit clipped to +-c; False
  trains on the raw logit), ``spectral_iteration`` ("fixed", Braxlines: one power iteration per
  call from the initial vector; "persistent": the vector is carried across SGD steps),
  ``target_seed`` (default 0: the PRNG seed of the default target's 250 samples, drawn once; the
  draw is not balanced between modes, e.g. seed 0 puts 131 of 250 at (+4, 0) for the ant).
  """
  return preset


gail = _dmin_preset("gail", lambda c: dmin.gail_reward,
                    "GAIL: r = -log(1 - D(s)) = softplus(l), non-negative.")
gail2 = _dmin_preset("gail2", lambda c: lambda l: dmin.gail2_reward(l, offset=c),
                     "GAIL2: r = log D(s) + c = -softplus(-l) + c.")
airl = _dmin_preset("airl", lambda c: lambda l: dmin.airl_reward(l, offset=c),
                    "AIRL: r = log D - log(1 - D) + c = l + c, non-negative for l in [-c, c].")
fairl = _dmin_preset("fairl", lambda c: lambda l: dmin.fairl_reward(l, offset=c),
                     "FAIRL: r = -l e^l + c.")


# ------------------------------------------------------------------------------------------------
# By name

_PRESETS: dict[str, Callable[..., Objective]] = {
    "task": task, "gcrl": gcrl, "fixed_gcrl": fixed_gcrl, "cdiayn": cdiayn, "diayn": diayn,
    "diayn_full": diayn_full, "gail": gail, "gail2": gail2, "airl": airl, "fairl": fairl,
    "mle": mle,
}


def list_objectives() -> list[str]:
  """The preset names ``make`` accepts."""
  return sorted(_PRESETS)


def options_of(name: str) -> list[str]:
  """The keyword options of preset ``name``."""
  return sorted(inspect.signature(_preset(name)).parameters)


def option_defaults(name: str) -> dict[str, Any]:
  """The keyword options of preset ``name`` that have a default, with it."""
  return {key: p.default for key, p in inspect.signature(_preset(name)).parameters.items()
          if p.default is not inspect.Parameter.empty}


def _preset(name: str) -> Callable[..., Objective]:
  if name not in _PRESETS:
    raise ValueError(f"unknown objective {name!r}; valid objectives are {list_objectives()}")
  return _PRESETS[name]


def make(name: str, **options: Any) -> Objective:
  """Builds preset ``name`` with ``options``; unknown names and options fail with the valid ones."""
  fn = _preset(name)
  check_names(f"objective {name!r}", options, keyword_names(fn), "option")
  return fn(**options)
