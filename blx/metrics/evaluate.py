"""Evaluation helpers: roll out a trained policy for a set of skills or goals and feed the metrics.

They follow Braxlines' evaluators (``../reference`` notes, section 4): the policy's sampled
actions (Braxlines' inference function samples; ``deterministic=True`` takes the mean action
instead), 10 skills (all K one-hots for a categorical prior, the single value of a deterministic
one) x 10 episodes, the last 500 steps, 1000 bins over +-obs_scale per dimension; 10 goals for LGR
drawn from U(-obs_scale, obs_scale)^d with seed 0; for D-min 10 episodes, every 10th of the last
500 steps.

Every ``*_evaluator`` returns an ``Evaluator``: a pure function ``(policy, params, key) -> metrics``
that is jit- and vmap-able (``blx.training.train(..., evaluate=...)`` vmaps it over seeds), whose
``episodes`` hands its episodes over unrun so that they can be stepped beside others
(``blx.envs.rollout_together``; ``train`` runs them with PPO's own evaluation episodes). ``policy``
is ``policy(params, obs [N, O], z [N, Z] | None, key=..., deterministic=...) -> action``
(``TrainResult.policy``) and ``params`` is what it acts with, a ``blx.training.PolicyParams``
(the MI-max evaluator also reads ``params.objective`` to infer the skill for each goal).
``evaluate_mimax`` / ``evaluate_dmin`` call one directly.
"""

from __future__ import annotations

import contextlib
import dataclasses
from typing import Any, Callable

import chex
import jax
import jax.numpy as jnp
import numpy as np

from blx import envs as envs_lib
from blx.metrics import particle
from blx.objectives.base import Objective
from blx.objectives.specs import DminSpec, MimaxSpec

__all__ = ["rollout", "episode_batch", "Evaluator", "latents_for_evaluation", "eval_indices",
           "lgr_goals", "LGR_GOAL_DRAWS", "infer_goal_latents", "mimax_evaluator",
           "dmin_evaluator", "mode_shares", "mode_balance", "alive_share", "alive_mask",
           "braxlines_end", "braxlines_window", "braxlines_mutual_information", "evaluate_mimax",
           "evaluate_dmin"]


def rollout(env: Any, policy: Callable, params: dict, latents: jax.Array, key: jax.Array, *,
            episodes_per_latent: int, conditions_policy: bool = True,
            deterministic: bool = False, record: Callable | None = None) -> Any:
  """Episodes for each latent: observations ``[L, M, T, O]`` (T policy steps), or with ``record``
  (``(state, action, next_state) -> pytree`` of batched leaves ``[N, ...]``) that pytree, each leaf
  ``[L, M, T, ...]``.

  ``env`` runs as given: one episode is its ``episode_length`` (over its ``action_repeat``) policy
  steps. Actions are sampled from the policy (as Braxlines' evaluation) unless ``deterministic``,
  which takes the mean action. There is no auto-reset and a terminated episode is not frozen: as in
  Braxlines' evaluation envs (``auto_reset=False``), the physics and the policy go on for the whole
  episode, so a fallen agent's later states are what it then does, not copies of the state it fell
  in.
  """
  batch, shape = episode_batch(env, policy, params, latents, key,
                               episodes_per_latent=episodes_per_latent,
                               conditions_policy=conditions_policy, deterministic=deterministic,
                               record=record)
  return shape(envs_lib.rollout_together([batch])[0])


def episode_batch(env: Any, policy: Callable, params: dict, latents: jax.Array, key: jax.Array, *,
                  episodes_per_latent: int, conditions_policy: bool = True,
                  deterministic: bool = False,
                  record: Callable | None = None) -> tuple[envs_lib.Episodes, Callable]:
  """The episodes of ``rollout`` (same arguments) handed over unrun, as ``blx.envs.Episodes``, and
  the function that shapes their records ``[T, N, ...]`` into ``rollout``'s ``[L, M, T, ...]``."""
  steps = envs_lib.episode_steps(env, "rollout")  # also refuses an env that resets itself
  num_latents = latents.shape[0]
  n = num_latents * episodes_per_latent
  z = jnp.repeat(latents, episodes_per_latent, axis=0)
  reset_key, action_key = jax.random.split(key)
  state = jax.vmap(env.reset)(jax.random.split(reset_key, n))

  def act(obs, step_key):
    return policy(params, obs, z if conditions_policy else None, key=step_key,
                  deterministic=deterministic)

  def shape(out):
    return jax.tree.map(  # [T, N, ...] -> [L, M, T, ...]
        lambda x: jnp.swapaxes(x, 0, 1).reshape((num_latents, episodes_per_latent, steps)
                                                + x.shape[2:]), out)

  record = record or (lambda state, action, next_state: next_state.obs)
  return envs_lib.Episodes(env, state, act, record, action_key, steps), shape


@dataclasses.dataclass(frozen=True)
class Evaluator:
  """One of the paper's evaluators. Called as ``(policy, params, key) -> metrics`` it runs its
  episodes and scores them. ``episodes(policy, params, key) -> (blx.envs.Episodes, score)`` hands
  the episodes over unrun, with ``score(records) -> metrics``, for a caller that steps them beside
  other episodes of the same env (``blx.envs.rollout_together``): the metrics are the same."""

  episodes: Callable[[Callable, Any, jax.Array], tuple[envs_lib.Episodes, Callable]]

  def __call__(self, policy: Callable, params: Any, key: jax.Array) -> dict:
    batch, score = self.episodes(policy, params, key)
    return score(envs_lib.rollout_together([batch])[0])


_FIXED_PRIORS = ("categorical", "deterministic")  # prior kinds whose latents are read, not drawn


def draws_latents(objective: Objective) -> bool:
  """Whether ``latents_for_evaluation`` draws an objective's latents from its prior (a continuous
  one: any kind but "categorical" and "deterministic", e.g. cDIAYN's and GCRL's "uniform") rather
  than reading fixed ones (every skill, or the single value). False for an objective without a
  prior (D-min)."""
  spec = objective.spec
  return isinstance(spec, MimaxSpec) and spec.prior.kind not in _FIXED_PRIORS


def latents_for_evaluation(objective: Objective, key: jax.Array, num_latents: int) -> jax.Array:
  """All K one-hots (categorical prior), the single value (deterministic) or, where
  ``draws_latents``, ``num_latents`` samples of the prior (continuous): ``[L, Z]``."""
  _check_spec(objective, MimaxSpec, "latents_for_evaluation")
  prior = objective.spec.prior
  if draws_latents(objective):
    return jax.vmap(prior.sample)(jax.random.split(key, num_latents))
  if prior.kind == "categorical":
    return jnp.eye(prior.dim)
  return prior.sample(key)[None]


# How the LGR goals are drawn from PRNGKey(0) (``lgr_goals``): "braxlines", the random bits of the
# JAX the paper ran on (threefry as it was before JAX 0.5 made it partitionable, so the paper's
# own goals); "partitionable", the bits of today's default, which blx drew its goals with before
# session 41 (other goals from the same key: a deviation, kept to finish and to compare runs
# made with it). The first is the evaluators' default.
LGR_GOAL_DRAWS = ("braxlines", "partitionable")


def lgr_goals(objective: Objective, num_goals: int = 10,
              draw: str = LGR_GOAL_DRAWS[0]) -> jax.Array:
  """The goals of latent goal reaching (paper Algorithm 2), ``[G, D]`` over the evaluated dims
  (``eval_indices``): ``num_goals`` draws of U(-obs_scale, obs_scale)^D from ``PRNGKey(0)``, the
  same for every evaluation. ``draw`` (``LGR_GOAL_DRAWS``) picks the random bits: "braxlines",
  those of the JAX Braxlines ran on, gives the paper's goals whatever this JAX's default;
  "partitionable" those of JAX's default since 0.5."""
  _check_spec(objective, MimaxSpec, "lgr_goals")
  if num_goals < 1:
    raise ValueError(f"lgr_goals: num_goals {num_goals}: give 1 or more")
  if draw not in LGR_GOAL_DRAWS:
    raise ValueError(f"lgr_goals: draw {draw!r}: valid are {', '.join(LGR_GOAL_DRAWS)}")
  scale = objective.spec.obs_scale
  shape = (num_goals, len(eval_indices(objective)))
  bits = getattr(jax, "threefry_partitionable", None)
  if bits is None and draw != "partitionable":  # a JAX past the setting draws those bits alone
    raise ValueError(f"lgr_goals: this JAX ({jax.__version__}) has no threefry_partitionable "
                     f"setting to draw the paper's goals with; valid here is "
                     f"draw='partitionable' alone")
  with contextlib.nullcontext() if bits is None else bits(draw == "partitionable"):
    return jax.random.uniform(jax.random.PRNGKey(0), shape, minval=-scale, maxval=scale)


def infer_goal_latents(env: Any, objective: Objective, objective_params: Any,
                       goals: jax.Array) -> jax.Array:
  """The latent inferred for each goal ``[G, D]``, ``[G, Z]``: the goal is set into an otherwise
  zero observation at the evaluated dims and read by the objective's ``infer_latent`` (the mean of
  q(z|g), or the one-hot of its most likely skill), as Algorithm 2 does."""
  _check_spec(objective, MimaxSpec, "infer_goal_latents")
  indices = np.asarray(eval_indices(objective))
  goal_obs = jnp.zeros((goals.shape[0], envs_lib.unwrap(env).observation_size))
  goal_obs = goal_obs.at[:, indices].set(goals)
  return jax.vmap(objective.spec.infer_latent, (None, 0))(objective_params, goal_obs)


def eval_indices(objective: Objective) -> tuple[int, ...]:
  """The observation dimensions evaluation looks at (``obs_indices``, or diayn_full's named ones)."""
  spec = objective.spec
  indices = getattr(spec, "eval_indices", None) or getattr(spec, "obs_indices", None)
  if not indices:
    raise ValueError(f"{objective.name}: evaluation needs the observation dimensions to look at; "
                     "build the objective with obs_indices=... (e.g. 'vel_xy' with env=)")
  return tuple(indices)


def _check_spec(objective: Objective, spec_type: type, helper: str) -> None:
  if not isinstance(objective.spec, spec_type):
    raise ValueError(f"{helper}: objective {objective.name!r} has a {type(objective.spec).__name__}"
                     f", not a {spec_type.__name__}")


def mimax_evaluator(env: Any, objective: Objective, *, num_latents: int = 10,
                    episodes_per_latent: int = 10, last_steps: int = 500, bins: int = 1000,
                    num_goals: int = 10, coverage_cell: float = 1.0,
                    deterministic: bool = False,
                    goal_draw: str = LGR_GOAL_DRAWS[0]) -> Evaluator:
  """``(policy, params, key) -> metrics`` for an MI-max objective.

  The skill episodes (MI, H(s), coverage) and the goal episodes (LGR) run side by side in one
  batched rollout, so an evaluation costs one episode of wall time.

  Metrics (``obs_scale`` = s, dims = the evaluated obs indices):
    ``eval/mi``, ``eval/entropy``, ``eval/conditional_entropy``: the 1-D particle estimates
    (paper Algorithm 1, 1000 bins over [-s, s]) averaged over dims, and per dim
    ``eval/mi_1d/<obs index>``; ``eval/mi_2d``: the 2-D estimate (30 x 30 bins) of the first two
    dims; ``eval/lgr`` and ``eval/lgr_1d/<obs index>`` (Algorithm 2, goals ~ U(-s, s)^d, seed 0,
    drawn as ``goal_draw`` says: ``lgr_goals``);
    ``eval/coverage``: distinct unit cells of the first two dims visited (all skills together);
    ``eval/alive_share``: the share of the skill episodes' scored states (the last
    ``last_steps``) taken before their episode ended (a fall). The other metrics count every
    state, as Braxlines' do; this one says how many of them a fallen body gave.
    ``eval/mi_alive``, ``eval/entropy_alive``: diagnostics, not the protocol's metrics: MI and
    H(s) of those states alone (a skill whose every scored state came after its falls drops out),
    which tell how much of a low MI the states after the falls account for.
    ``eval/mi_braxlines``, ``eval/entropy_braxlines``: MI and H(s) of the skill episodes in the
    window Braxlines' rollout scores (``braxlines_window``). They equal ``eval/mi`` and
    ``eval/entropy`` (up to a one-step shift of the window) unless every skill episode is done at
    once before the step limit; then Braxlines' rollout stops there and scores the states before
    it, which a fixed window would miss. (LGR keeps the fixed window.)
  """
  _check_spec(objective, MimaxSpec, "mimax_evaluator")
  indices = np.asarray(eval_indices(objective))
  scale = objective.spec.obs_scale
  value_range = (-scale, scale)
  goals = lgr_goals(objective, num_goals, goal_draw)

  def episodes(policy, params, key):
    z_key, roll_key = jax.random.split(key)
    latents = latents_for_evaluation(objective, z_key, num_latents)
    goal_latents = infer_goal_latents(env, objective, params.objective, goals)
    batch, shape = episode_batch(env, policy, params, jnp.concatenate([latents, goal_latents]),
                                 roll_key, episodes_per_latent=episodes_per_latent,
                                 deterministic=deterministic, record=record)
    return batch, lambda records: score(*shape(records), latents.shape[0])

  def record(state, action, next_state):
    return next_state.obs, next_state.done, state.obs[..., indices]

  def score(obs, done, before, num):
    everything = obs[..., indices]
    states = everything[:num, :, -last_steps:]  # [L, M, T, D]
    reached = everything[num:]
    labels = jnp.repeat(jnp.arange(num), states.shape[1] * states.shape[2])
    flat = states.reshape(-1, len(indices))
    mi = particle.mutual_information(flat, labels, bins=bins, value_range=value_range,
                                     num_labels=num)
    out = {"eval/mi": mi["mi"].mean(), "eval/entropy": mi["entropy"].mean(),
           "eval/conditional_entropy": mi["conditional_entropy"].mean()}
    out.update({f"eval/mi_1d/{i}": mi["mi"][k] for k, i in enumerate(indices)})
    if len(indices) >= 2:
      out["eval/mi_2d"] = particle.mutual_information_2d(
          flat[:, :2], labels, bins=30, value_range=value_range, num_labels=num)["mi"]
      out["eval/coverage"] = particle.state_coverage(flat[:, :2], cell=coverage_cell)
    alive = alive_mask(done[:num], last_steps).reshape(-1)
    out["eval/alive_share"] = alive.mean()
    kept = particle.mutual_information(flat, labels, bins=bins, value_range=value_range,
                                       num_labels=num, weights=alive)
    out["eval/mi_alive"] = kept["mi"].mean()
    out["eval/entropy_alive"] = kept["entropy"].mean()
    brax = braxlines_mutual_information(before[:num], done[:num], last_steps, bins=bins,
                                        value_range=value_range)
    out["eval/mi_braxlines"] = brax["mi"].mean()
    out["eval/entropy_braxlines"] = brax["entropy"].mean()
    lgr = particle.latent_goal_reaching(reached, goals, last_steps=last_steps)
    out["eval/lgr"] = lgr["lgr"]
    out.update({f"eval/lgr_1d/{i}": lgr["lgr_1d"][k] for k, i in enumerate(indices)})
    return out

  return Evaluator(episodes)


def dmin_evaluator(env: Any, objective: Objective, *, num_episodes: int = 10,
                   last_steps: int = 500, every: int = 10,
                   deterministic: bool = False) -> Evaluator:
  """``(policy, params, key) -> {"eval/energy_distance"}`` for a D-min objective: the energy
  distance between the policy's indexed states (``num_episodes`` episodes, every ``every``-th of
  the last ``last_steps`` steps, actions sampled unless ``deterministic``) and the target samples,
  with ``eval/mode_share/k`` (``mode_shares``) for a target of several modes and
  ``eval/alive_share`` (as in ``mimax_evaluator``: the share of the scored states taken before
  their episode ended) and ``eval/energy_distance_braxlines``: the energy distance of the window
  Braxlines' rollout scores (``braxlines_window``). The two energy distances agree (up to a
  one-step shift of the window) unless every episode is done at once before the step limit; then
  Braxlines' rollout stops there and scores the states before it (the reset state included),
  where the fixed window scores the fallen bodies."""
  _check_spec(objective, DminSpec, "dmin_evaluator")
  indices = np.asarray(objective.spec.obs_indices)
  target = jnp.asarray(objective.spec.target.samples)[:, :len(indices)]
  means = objective.spec.target.means

  def episodes(policy, params, key):
    batch, shape = episode_batch(env, policy, params, jnp.zeros((1, 0)), key,
                                 episodes_per_latent=num_episodes, conditions_policy=False,
                                 deterministic=deterministic, record=record)
    return batch, lambda records: score(*shape(records))

  def record(state, action, next_state):
    return next_state.obs[..., indices], next_state.done, state.obs[..., indices]

  def score(states, done, before):
    x = states[0, :, -last_steps:][:, ::every]  # [episodes, samples, D]
    # Braxlines' window holds at most x's number of states per episode: gather them, not all T.
    window = braxlines_window(done[0], last_steps, every)
    kept = jnp.nonzero(window, size=x.shape[1], fill_value=0)[0]
    valid = (jnp.arange(x.shape[1]) < window.sum()).astype(jnp.float32)
    brax = before[0][:, kept]                   # [episodes, samples, D]
    out = {"eval/energy_distance": particle.energy_distance(x.reshape(-1, len(indices)), target),
           "eval/alive_share": alive_share(done[0], last_steps, every),
           "eval/energy_distance_braxlines": particle.energy_distance(
               brax.reshape(-1, len(indices)), target,
               weights=jnp.broadcast_to(valid, brax.shape[:2]).reshape(-1))}
    if means is not None and len(means) > 1:
      out.update(mode_shares(x, jnp.asarray(means)[:, :len(indices)]))
    return out

  return Evaluator(episodes)


def alive_mask(done: jax.Array, last_steps: int, every: int = 1) -> jax.Array:
  """1.0 for each scored state taken before its episode ended, else 0.0: ``done [..., T]`` (the
  env's done flag after each step, episodes on the leading axes), the states scored being every
  ``every``-th of the last ``last_steps`` steps (``[..., ceil(last_steps / every)]``). The step
  that ends an episode still counts (its state is the one the episode ended in); the steps after
  it do not."""
  alive = envs_lib.alive_before(jnp.moveaxis(done.astype(jnp.float32), -1, 0))
  return jnp.moveaxis(alive, 0, -1)[..., -last_steps:][..., ::every]


def braxlines_end(done: jax.Array) -> jax.Array:
  """E, the step before which Braxlines' rollout of a batch stops: the first E >= 1 at which every
  episode's done flag is 1 at once (``done [..., T]`` holds the flags of s_1 .. s_T, per step; all
  leading axes are episodes of one batch), or T if that never happens."""
  all_done = jnp.all(done.reshape(-1, done.shape[-1]) > 0, axis=0)      # [T]: s_1 .. s_T
  return jnp.where(jnp.any(all_done), jnp.argmax(all_done) + 1, done.shape[-1])


def braxlines_window(done: jax.Array, last_steps: int, every: int = 1) -> jax.Array:
  """The states Braxlines' evaluators score, as a 0/1 mask over the states s_0 .. s_{T-1} that
  each step starts from (the reset state first).

  ``done [N, T]``: the done flag of s_1 .. s_T (the env's flag after each step, per step, not
  cumulative), for the N episodes of one evaluation batch. Braxlines' rollout keeps s_0, s_1, ...
  while not every episode of the batch is done at once, so it stops before the first E >= 1 at
  which all N flags are 1 (``braxlines_end``; E = T if they never are: the step limit sets them
  at T). Its evaluators
  then score the last ``last_steps`` states it kept, every ``every``-th from the first of those:
  s_j for j in [max(0, E - last_steps), E) with (j - max(0, E - last_steps)) % every == 0. So where
  every episode of the batch ends early, the window moves to before the ends, reset state
  included; blx's fixed window (the last ``last_steps`` of T steps) scores the fallen bodies
  instead. Returns ``[T]`` (the same window for every episode of the batch)."""
  chex.assert_rank(done, 2)
  steps = done.shape[1]
  end = braxlines_end(done)
  start = jnp.maximum(0, end - last_steps)
  j = jnp.arange(steps)
  return ((j >= start) & (j < end) & ((j - start) % every == 0)).astype(jnp.float32)


def braxlines_mutual_information(states: jax.Array, done: jax.Array, last_steps: int, *,
                                 bins: int, value_range: tuple[float, float]) -> dict:
  """``particle.mutual_information`` of skill episodes in Braxlines' window: ``states [L, M, T, D]``
  the states s_0 .. s_{T-1} each step starts from, for L skills of M episodes (one evaluation
  batch), ``done [L, M, T]`` their per-step done flags; the labels are the skills. Each skill's
  states are weighted by ``braxlines_window`` over the whole batch."""
  chex.assert_rank([states, done], [4, 3])
  num, per_skill = states.shape[0], states.shape[1] * states.shape[2]
  window = braxlines_window(done.reshape(-1, done.shape[-1]), last_steps)
  return particle.mutual_information(
      states.reshape(-1, states.shape[-1]), jnp.repeat(jnp.arange(num), per_skill), bins=bins,
      value_range=value_range, num_labels=num,
      weights=jnp.broadcast_to(window, states.shape[:3]).reshape(-1))


def alive_share(done: jax.Array, last_steps: int, every: int = 1) -> jax.Array:
  """The share of scored states taken before their episode ended (``alive_mask``'s mean); 1.0
  when no episode ends."""
  return alive_mask(done, last_steps, every).mean()


def mode_shares(x: jax.Array, means: jax.Array) -> dict[str, jax.Array]:
  """How samples ``x [episodes, samples, D]`` share out among a target's modes ``means [K, D]``.

  ``eval/mode_share/k``: the fraction of all samples nearest to mode k (the target's own share is
  1 / K for Braxlines' equal-weight mixtures). ``eval/episode_mode_share/k``: the fraction of episodes
  whose samples are mostly nearest to mode k. Together they tell a policy whose episodes each pick
  a mode from one that visits every mode within an episode, and one that covers a single mode.
  ``eval/mode_balance``: ``mode_balance`` of the sample shares, 1 for an even split and 0 where a
  mode is never visited.
  """
  nearest = jnp.argmin(((x[..., None, :] - means) ** 2).sum(-1), axis=-1)  # [episodes, samples]
  onehot = jax.nn.one_hot(nearest, len(means))
  per_episode = onehot.mean(1)  # [episodes, K]
  majority = jax.nn.one_hot(jnp.argmax(per_episode, -1), len(means)).mean(0)
  out = {}
  for k in range(len(means)):
    out[f"eval/mode_share/{k}"] = per_episode[:, k].mean()
    out[f"eval/episode_mode_share/{k}"] = majority[k]
  out["eval/mode_balance"] = mode_balance(per_episode.mean(0))
  return out


def mode_balance(shares: jax.Array) -> jax.Array:
  """How evenly samples share out among K modes: K times the least share, over the last axis of
  ``shares [..., K]`` (each row summing to 1). 1 for an even split (the share of an equal-weight
  target), 0 where a mode gets no sample: a policy that commits to one mode of two scores 0, one
  that splits 60/40 scores 0.8. It says nothing of reaching the modes (a body standing still
  midway splits evenly): read it beside the energy distance."""
  shares = jnp.asarray(shares)
  return shares.shape[-1] * shares.min(-1)


def evaluate_mimax(env: Any, objective: Objective, params: dict, key: jax.Array, *,
                   policy: Callable, **settings) -> dict:
  """Runs ``mimax_evaluator(env, objective, **settings)`` once under jit; floats out."""
  fn = mimax_evaluator(env, objective, **settings)
  return {k: float(v) for k, v in jax.jit(lambda p, k: fn(policy, p, k))(params, key).items()}


def evaluate_dmin(env: Any, objective: Objective, params: dict, key: jax.Array, *,
                  policy: Callable, **settings) -> dict:
  """Runs ``dmin_evaluator(env, objective, **settings)`` once under jit; floats out."""
  fn = dmin_evaluator(env, objective, **settings)
  return {k: float(v) for k, v in jax.jit(lambda p, k: fn(policy, p, k))(params, key).items()}
