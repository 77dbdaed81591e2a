"""One PPO for every objective, as pure functions: ``make_train(env, objective, config)(key)``.

The whole run is a pure function of a PRNG key, so ``jax.jit(jax.vmap(train))(keys)`` trains several
seeds in one program. Data parallelism shards the env axis over all local devices with
``jax.sharding`` (the same code on 1 or N devices; XLA inserts the gradient all-reduce).

One iteration: roll out ``num_envs`` envs for ``num_unrolls`` x ``unroll_length`` steps with the
objective's reward -> update the observation normaliser -> ``num_updates_per_batch`` epochs of
``num_minibatches`` SGD steps on PPO's loss plus the objective's loss, one Adam over both.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from blx import envs as envs_lib
from blx.envs.env import State
from blx.objectives.base import Objective, Transition
from blx.training import losses, networks
from blx.training.config import PPOConfig

__all__ = ["Params", "PolicyParams", "TrainState", "Trainer", "Learner", "make_learner",
           "make_trainer", "make_train", "make_policy", "network_input", "policy_params", "env_step",
           "collect", "ppo_loss", "sgd_step", "update", "evaluate", "place_state", "run_chunks",
           "RETURN_KEYS"]


@struct.dataclass
class Params:
  """Everything SGD updates: policy, value and the objective's parameters."""

  policy: Any
  value: Any
  objective: Any


class PolicyParams(NamedTuple):
  """What acting and evaluating need, exported by training (one seed, or a leading seed axis).

  Attributes:
    normalizer: the running statistics of the policy's input.
    policy: the policy network's parameters.
    objective: the objective's parameters (evaluation infers skills for goals with them; plots
      draw the discriminator).
  """

  normalizer: networks.RunningStats
  policy: Any
  objective: Any = None


@struct.dataclass
class TrainState:
  """The training state of one seed (a pytree; the loop carry)."""

  params: Params
  opt_state: Any
  normalizer: networks.RunningStats
  env_state: State
  z: jax.Array            # [num_envs, latent_size], fixed per env for the whole run
  key: jax.Array
  env_steps: jax.Array
  iteration: jax.Array


class Rollout(NamedTuple):
  """Collected steps; leaves are ``[..., num_envs]`` during collection, ``[N, T]`` for SGD."""

  obs: jax.Array
  raw_action: jax.Array
  action: jax.Array
  log_prob: jax.Array
  next_obs: jax.Array
  reward: jax.Array
  env_reward: jax.Array
  done: jax.Array
  truncation: jax.Array
  z: jax.Array


class Trainer(NamedTuple):
  """The pure pieces of a run; ``train`` composes them, the host loop calls them in chunks.

  Attributes:
    init: ``key -> TrainState``.
    chunk: ``(TrainState, length=iterations_per_chunk) -> (TrainState, metrics)``, ``length``
      iterations (a static int: a chunk run in segments, ``train(checkpoint_segments=...)``, is
      the same iterations); metrics have a leading ``[length]`` axis. One iteration is
      ``update(*collect(state))``.
    collect: ``TrainState -> (TrainState, Rollout)``: the rollout half of an iteration (policy,
      physics, the objective's reward); sequences ``[num_unrolls * num_envs, unroll_length]``.
    update: ``(TrainState, Rollout) -> (TrainState, metrics)``: the learning half (normaliser,
      PPO and objective losses, SGD). Profilers time the halves apart.
    evaluate: ``(PolicyParams, key) -> metrics`` from episodes on fresh envs (mean or sampled
      actions, ``PPOConfig.eval_actions``).
    evaluation_episodes: ``(PolicyParams, key) -> (blx.envs.Episodes, score)``: ``evaluate``'s
      episodes unrun and ``score(records) -> metrics``, to step beside an evaluator's
      (``blx.envs.rollout_together``); ``evaluate`` is ``score`` of their records.
    train: ``key -> (TrainState, metrics)``, the whole run: ``num_chunks`` chunks, each followed by an
      evaluation; metrics have a leading ``[num_chunks]`` axis.
    policy: ``(params: PolicyParams, obs, z=None, key=None, deterministic=True) -> action``.
  """

  init: Callable[[jax.Array], TrainState]
  chunk: Callable[..., tuple[TrainState, dict]]
  collect: Callable[[TrainState], tuple[TrainState, "Rollout"]]
  update: Callable[[TrainState, "Rollout"], tuple[TrainState, dict]]
  evaluate: Callable[[PolicyParams, jax.Array], dict]
  evaluation_episodes: Callable[[PolicyParams, jax.Array], tuple[envs_lib.Episodes, Callable]]
  train: Callable[[jax.Array], tuple[TrainState, dict]]
  policy: Callable[..., jax.Array]
  num_chunks: int
  iterations_per_chunk: int
  config: PPOConfig
  env_steps_per_iteration: int  # counting the env's action repeats


def _data_mesh(num_envs: int) -> Mesh | None:
  """The mesh the env axis is split over: all local devices; None on one device."""
  devices = jax.local_devices()
  if len(devices) == 1:
    return None
  if num_envs % len(devices):
    raise ValueError(f"num_envs={num_envs} must be divisible by the {len(devices)} local devices")
  return Mesh(np.array(devices), ("data",))


def _data_sharding(num_envs: int) -> Callable[[Any], Any]:
  """Constrains leaves with a leading env axis to be split over all local devices."""
  mesh = _data_mesh(num_envs)
  if mesh is None:
    return lambda tree: tree
  sharding = NamedSharding(mesh, PartitionSpec("data"))
  return lambda tree: jax.tree.map(
      lambda x: jax.lax.with_sharding_constraint(x, sharding) if x.ndim else x, tree)


def place_state(state: TrainState, num_envs: int) -> TrainState:
  """A state batched over seeds (``[seeds, ...]`` leaves, as ``train`` holds it) laid out on the
  local devices as a chunk keeps it: the env axis (axis 1) of ``env_state`` and ``z`` split over
  the devices, everything else replicated on each. Unchanged on one device.

  A chunk compiled ahead of time takes its inputs only in the layout it was compiled for. A state
  restored from a checkpoint comes back on one device, where the chunk's result is spread over
  all: compiled for the first, the programs refuse the second after the first chunk."""
  mesh = _data_mesh(num_envs)
  if mesh is None:
    return state
  split = NamedSharding(mesh, PartitionSpec(None, "data"))
  whole = NamedSharding(mesh, PartitionSpec())
  # (XLA keeps an empty leaf whole; so does the layout, which the chunk's result then matches.)
  per_env = lambda tree: jax.tree.map(lambda x: split if x.ndim > 1 and x.size else whole, tree)
  layout = jax.tree.map(lambda _: whole, state).replace(env_state=per_env(state.env_state),
                                                        z=per_env(state.z))
  return jax.device_put(state, layout)


def _transitions(batch: Rollout) -> Transition:
  """Sequences ``[B, T, ...]`` flattened into the objective's ``[B * T, ...]`` transitions."""
  flat = lambda x: x.reshape((x.shape[0] * x.shape[1],) + x.shape[2:])
  return Transition(flat(batch.obs), flat(batch.action), flat(batch.next_obs),
                    flat(batch.env_reward), flat(batch.z))


def network_input(stats: networks.RunningStats, obs: jax.Array, z: jax.Array | None, *,
                  normalize_observations: bool, normalize_latent: bool) -> jax.Array:
  """The policy's and value's input ``[..., O (+ Z)]``.

  With ``normalize_latent`` the running normaliser covers [obs, z] together (Braxlines: z is part of
  the observation); otherwise only obs is normalised and z is appended as it is.
  """
  if z is None or not z.shape[-1]:
    return networks.normalize(stats, obs, normalize_observations)
  if normalize_latent:
    return networks.normalize(stats, jnp.concatenate([obs, z], axis=-1), normalize_observations)
  return jnp.concatenate([networks.normalize(stats, obs, normalize_observations), z], axis=-1)


def make_policy(policy_net: networks.MLP, normalize_observations: bool,
                normalize_latent: bool = True) -> Callable:
  """The inference function ``policy(params, obs, z=None, key=None, deterministic=True)``."""

  def policy(params, obs, z=None, key=None, deterministic=True):
    x = network_input(params.normalizer, obs, z, normalize_observations=normalize_observations,
                      normalize_latent=normalize_latent)
    logits = policy_net.apply(params.policy, x)
    if deterministic:
      return networks.deterministic_action(logits)
    if key is None:
      raise ValueError("policy: a key is needed when deterministic=False")
    return jnp.tanh(networks.sample_raw_action(logits, key))

  return policy


class Learner(NamedTuple):
  """What one run's pieces share: the networks, the optimiser, the objective and the config.

  Every piece below (``env_step``, ``collect``, ``ppo_loss``, ``sgd_step``, ``update``,
  ``evaluate``) is a module-level function of a ``Learner`` and its data, so each can be called and
  tested on its own; ``make_trainer`` binds them into a ``Trainer``.
  """

  policy_net: networks.MLP
  value_net: networks.MLP
  optimizer: optax.GradientTransformation
  objective: Objective
  config: PPOConfig
  stats_size: int         # width of the running normaliser: obs, plus z when it is normalised too
  action_repeat: int = 1  # the env's: env steps per policy step
  agent_names: tuple[str, ...] = ()  # MAPPO: the env's agents (reward, value, log-prob per agent)
  action_groups: Any = None          # MAPPO: [action_size, num_agents], 1 where an agent acts

  @property
  def num_agents(self) -> int:
    return len(self.agent_names) or 1

  def log_prob(self, logits: jax.Array, raw_action: jax.Array) -> jax.Array:
    """log pi(u): ``[...]``, or per agent ``[..., num_agents]`` for MAPPO."""
    return networks.log_prob_raw(logits, raw_action, self.action_groups)

  def value(self, params: Any, x: jax.Array) -> jax.Array:
    """V(x): ``[...]``, or per agent ``[..., num_agents]`` for MAPPO."""
    values = self.value_net.apply(params, x)
    return values if self.agent_names else values[..., 0]

  @property
  def latent_in_stats(self) -> bool:
    c, o = self.config, self.objective
    return o.conditions_policy and c.normalize_latent and o.latent_size > 0

  def policy_input(self, stats: networks.RunningStats, obs: jax.Array, z: jax.Array) -> jax.Array:
    """The policy's and value's input for ``obs`` and the env's latent ``z``."""
    return network_input(stats, obs, z if self.objective.conditions_policy else None,
                         normalize_observations=self.config.normalize_observations,
                         normalize_latent=self.config.normalize_latent)


def make_learner(obs_size: int, action_size: int, objective: Objective,
                 config: PPOConfig, action_repeat: int = 1,
                 agents: envs_lib.AgentGroups | None = None) -> Learner:
  """The networks (policy ``[*policy_hidden, 2 A]``, value ``[*value_hidden, 1]``) and the
  optimiser (global-norm clipping, then Adam) for an env of these sizes.

  With ``agents`` (a multi-agent env's ``env.agents``) this is MAPPO, Braxlines' multi-agent PPO:
  each agent has its own policy and value network (``networks.AgentMLPs``) on the shared,
  commonly normalised observation; its policy acts on its own actuators; GAE and the clipped
  surrogate use its own reward column and its own log-probability, with the episode ends shared.
  One Adam over all agents' parameters updates each agent's networks by its own loss alone (Adam
  is per parameter; the losses of different agents share no parameters), as separate optimisers
  would, unless ``max_grad_norm`` clips the global norm of all of them together.
  """
  c = config
  optimizer = optax.chain(
      optax.clip_by_global_norm(c.max_grad_norm) if c.max_grad_norm else optax.identity(),
      optax.adam(c.learning_rate))
  policy_net = networks.MLP((*c.policy_hidden, 2 * action_size))
  value_net = networks.MLP((*c.value_hidden, 1))
  names, groups = (), None
  if agents is not None:
    names = tuple(agents.names)
    acts = [np.asarray(agents.action_indices[a], np.int64) for a in names]
    policy_net = networks.AgentMLPs(
        c.policy_hidden, names, tuple(tuple(np.concatenate([i, action_size + i]).tolist())
                                      for i in acts), 2 * action_size)
    value_net = networks.AgentMLPs(c.value_hidden, names, tuple((k,) for k in range(len(names))),
                                   len(names))
    groups = np.zeros((action_size, len(names)), np.float32)
    for k, i in enumerate(acts):
      groups[i, k] = 1.0
  learner = Learner(policy_net=policy_net, value_net=value_net, optimizer=optimizer,
                    objective=objective, config=c, stats_size=obs_size,
                    action_repeat=action_repeat, agent_names=names, action_groups=groups)
  if learner.latent_in_stats:
    learner = learner._replace(stats_size=obs_size + objective.latent_size)
  return learner


def env_step(learner: Learner, env: Any, params: Params, stats: networks.RunningStats,
             z: jax.Array, env_state: State, key: jax.Array) -> tuple[State, Rollout]:
  """One step of every env ``[N]``: sample actions, step the physics, score with the objective."""
  objective = learner.objective
  with jax.named_scope("policy"):
    logits = learner.policy_net.apply(params.policy, learner.policy_input(stats, env_state.obs, z))
    raw = networks.sample_raw_action(logits, key)
    action = jnp.tanh(raw)
  with jax.named_scope("physics"):
    next_state = jax.vmap(env.step)(env_state, action)
  next_obs = next_state.pre_reset_obs
  transition = Transition(env_state.obs, action, next_obs, next_state.reward, z)
  with jax.named_scope("objective"):
    reward = jax.vmap(objective.reward, (None, 0))(
        jax.lax.stop_gradient(params.objective), transition)
  step = Rollout(env_state.obs, raw, action, learner.log_prob(logits, raw), next_obs, reward,
                 next_state.reward, next_state.done, next_state.truncation, z)
  return next_state, step


def collect(learner: Learner, env: Any, state: TrainState,
            shard: Callable[[Any], Any] = lambda tree: tree) -> tuple[TrainState, Rollout]:
  """``num_unrolls`` x ``unroll_length`` steps of every env of the auto-resetting ``env``:
  sequences ``[U * N, T, ...]``."""
  c = learner.config
  key, rollout_key = jax.random.split(state.key)
  num_envs = state.z.shape[0]

  def unroll(env_state, key):
    def one(env_state, key):
      next_state, step = env_step(learner, env, state.params, state.normalizer, state.z,
                                  env_state, key)
      return shard(next_state), step
    return jax.lax.scan(one, env_state, jax.random.split(key, c.unroll_length))

  env_state, data = jax.lax.scan(unroll, state.env_state,
                                 jax.random.split(rollout_key, c.num_unrolls))
  # [U, T, N, ...] -> [U * N, T, ...]: sequences of unroll_length steps.
  data = jax.tree.map(lambda x: jnp.swapaxes(x, 1, 2).reshape(
      (c.num_unrolls * num_envs, c.unroll_length) + x.shape[3:]), data)
  return state.replace(env_state=env_state, key=key), data


def ppo_loss(learner: Learner, params: Params, batch: Rollout, stats: networks.RunningStats,
             key: jax.Array) -> tuple[jax.Array, dict]:
  """PPO's loss plus the objective's on sequences ``[B, T]``: ``(scalar, metrics)``.

  Advantages come from one value pass over s_0 .. s_{T-1} and the true s'_{T-1}
  (``losses.sequence_advantages``): V(s'_t) = V(s_{t+1}) inside a sequence except after an
  auto-reset; terminations do not bootstrap, a truncation inside a sequence gets delta 0.
  """
  c, objective = learner.config, learner.objective
  entropy_key, obj_key = jax.random.split(key)
  x = learner.policy_input(stats, batch.obs, batch.z)
  with jax.named_scope("policy"):
    logits = learner.policy_net.apply(params.policy, x)
  with jax.named_scope("value"):
    x_last = learner.policy_input(stats, batch.next_obs[:, -1:], batch.z[:, -1:])
    values = learner.value(params.value, jnp.concatenate([x, x_last], axis=1))
  value = values[:, :-1]

  def advantages(reward, values):
    return losses.sequence_advantages(reward, values, batch.done, batch.truncation,
                                      discount=c.discounting, lam=c.gae_lambda)
  if learner.agent_names:  # one GAE per agent's reward column; episode ends are shared
    advantages = jax.vmap(advantages, in_axes=-1, out_axes=-1)
  advantage, target = advantages(batch.reward * c.reward_scaling, jax.lax.stop_gradient(values))
  if c.normalize_advantage:  # per agent
    advantage = ((advantage - advantage.mean((0, 1), keepdims=True))
                 / (advantage.std((0, 1), keepdims=True) + 1e-8))
  log_prob = learner.log_prob(logits, batch.raw_action)
  # Every agent has the same number of samples, so num_agents x the mean over [B, T, agents] is
  # the sum over agents of each agent's PPO loss (one agent: the loss itself).
  policy_loss = learner.num_agents * losses.clipped_surrogate(
      log_prob, batch.log_prob, advantage, epsilon=c.clipping_epsilon)
  value_loss = learner.num_agents * 0.25 * jnp.mean((value - target) ** 2)
  entropy = jnp.mean(networks.entropy(logits, entropy_key))
  entropy_loss = -c.entropy_cost * entropy
  with jax.named_scope("objective"):
    objective_loss, objective_metrics = objective.loss(params.objective, _transitions(batch),
                                                       obj_key)
  total = policy_loss + value_loss + entropy_loss + objective_loss
  metrics = {"loss/total": total, "loss/policy": policy_loss, "loss/value": value_loss,
             "loss/entropy": entropy_loss, "loss/objective": objective_loss,
             "policy/entropy": entropy,
             # exp of it is PPO's ratio, which overflows float32 above about 88.7
             "policy/log_ratio_max": jnp.max(log_prob - batch.log_prob), **objective_metrics}
  return total, metrics


def sgd_step(learner: Learner, carry, inputs):
  """One Adam step on ``ppo_loss`` of a minibatch; ``carry = (params, opt_state, stats)``."""
  params, opt_state, stats = carry
  batch, key = inputs
  grads, metrics = jax.grad(lambda p: ppo_loss(learner, p, batch, stats, key), has_aux=True)(params)
  updates, opt_state = learner.optimizer.update(grads, opt_state, params)
  params = optax.apply_updates(params, updates)
  post_update = learner.objective.post_update
  if post_update is not None:  # state outside the gradient, e.g. spectral-norm vectors
    params = params.replace(objective=post_update(params.objective, _transitions(batch)))
  metrics["grad_norm"] = norm = optax.global_norm(grads)
  metrics["nonfinite/grads"] = ~_all_finite(grads)
  if learner.config.max_grad_norm:  # 1 where the clip scaled this step down; averaged: its share
    metrics["grad_clipped"] = (norm > learner.config.max_grad_norm).astype(jnp.float32)
  return (params, opt_state, stats), metrics


def _all_finite(tree) -> jax.Array:
  """Whether every number in the pytree ``tree`` is finite, a scalar bool."""
  return jnp.all(jnp.stack([jnp.isfinite(x).all() for x in jax.tree.leaves(tree)]))


LOSS_TERMS = ("policy", "value", "entropy", "objective")


def _first_nonfinite_step(steps: dict) -> dict:
  """What went wrong at the first SGD step of an update whose loss or gradient was non-finite
  (``steps``: per-step metrics ``[S]``): whether the gradient was (``nonfinite/grads``), which of
  the loss's terms were (``nonfinite/loss/<term>``), and PPO's largest log-ratio there
  (``nonfinite/log_ratio_max``; above about 88.7 the ratio itself overflows float32). All False
  (the log-ratio 0) where every step was finite."""
  bad = ~jnp.isfinite(steps["loss/total"]) | steps["nonfinite/grads"]
  first, any_bad = jnp.argmax(bad), bad.any()
  out = {"nonfinite/grads": any_bad & steps["nonfinite/grads"][first]}
  out.update({f"nonfinite/loss/{t}": any_bad & ~jnp.isfinite(steps[f"loss/{t}"][first])
              for t in LOSS_TERMS})
  out["nonfinite/log_ratio_max"] = jnp.where(any_bad, steps["policy/log_ratio_max"][first], 0.0)
  return out


def reduce_stats(stats: dict, axis: int = 0, xp=jnp) -> dict:
  """Statistics reduced over ``axis`` (``xp``: ``jnp`` on the device, ``np`` on the host): a
  ``_max`` statistic to its largest, every other to its mean. An update reduces its SGD steps so,
  and ``train`` a chunk's iterations for its rows. The ``nonfinite/`` flags are left out: an
  update reports them by ``_first_nonfinite_step``, and ``train`` checks them per iteration."""
  return {k: (xp.max if k.endswith("_max") else xp.mean)(v, axis=axis) for k, v in stats.items()
          if not k.startswith("nonfinite/")}


def update(learner: Learner, state: TrainState, data: Rollout) -> tuple[TrainState, dict]:
  """Normaliser update, then ``num_updates_per_batch`` epochs of minibatch SGD on ``data``."""
  c = learner.config
  key, sgd_key = jax.random.split(state.key)
  num_sequences = data.obs.shape[0]
  normalizer = state.normalizer
  if c.normalize_observations:
    seen = jnp.concatenate([data.obs, data.z], -1) if learner.latent_in_stats else data.obs
    normalizer = networks.update_stats(normalizer, seen.reshape(-1, learner.stats_size))

  def epoch(carry, key):
    perm_key, step_key = jax.random.split(key)
    perm = jax.random.permutation(perm_key, num_sequences)
    batches = jax.tree.map(lambda x: x[perm].reshape(
        (c.num_minibatches, c.batch_size) + x.shape[1:]), data)
    keys = jax.random.split(step_key, c.num_minibatches)
    return jax.lax.scan(lambda carry, inputs: sgd_step(learner, carry, inputs), carry,
                        (batches, keys))

  (params, opt_state, _), steps = jax.lax.scan(
      epoch, (state.params, state.opt_state, normalizer),
      jax.random.split(sgd_key, c.num_updates_per_batch))
  steps = jax.tree.map(lambda x: x.reshape(-1), steps)  # [epochs * minibatches], in order
  metrics = reduce_stats(steps)
  metrics.update(_first_nonfinite_step(steps))
  metrics.update({f"train/reward/{a}": data.reward[..., i].mean()
                  for i, a in enumerate(learner.agent_names)})
  metrics.update({
      "train/reward": data.reward.mean(),
      "train/env_reward": data.env_reward.mean(),
      "train/episode_end_rate": data.done.mean(),
      "nonfinite/reward": ~jnp.isfinite(data.reward).all(),
      "nonfinite/loss": ~jnp.isfinite(metrics["loss/total"]),
      "nonfinite/params": ~_all_finite(params),
      "nonfinite/observation": ~(jnp.isfinite(data.obs).all() & jnp.isfinite(data.next_obs).all()),
  })
  state = state.replace(params=params, opt_state=opt_state, normalizer=normalizer, key=key,
                        env_steps=state.env_steps
                        + c.env_steps_per_iteration * learner.action_repeat,
                        iteration=state.iteration + 1)
  return state, metrics


# The episode totals of ``evaluate`` that a run reports as its returns (each, in a multi-agent
# run, also per agent: ``eval/episode_reward/<agent>``); its other keys are the env's terms.
RETURN_KEYS = ("eval/episode_reward", "eval/episode_score", "eval/episode_length")


def evaluate(learner: Learner, env: Any, steps: int, params: PolicyParams, key: jax.Array) -> dict:
  """Episode totals of ``num_eval_envs`` episodes of ``env`` (no auto-reset), at most ``steps``
  steps each, acting with the mean action or sampled ones (``PPOConfig.eval_actions``): the
  objective's reward, the env's reward and its per-term metrics."""
  batch, score = evaluation_episodes(learner, env, steps, params, key)
  return score(envs_lib.rollout_together([batch])[0])


def evaluation_episodes(learner: Learner, env: Any, steps: int, params: PolicyParams,
                        key: jax.Array) -> tuple[envs_lib.Episodes, Callable[[Any], dict]]:
  """``evaluate``'s episodes handed over unrun (``blx.envs.Episodes``), and ``score(records) ->
  metrics``, so that the host loop can step them beside an evaluator's."""
  c, objective = learner.config, learner.objective
  policy = make_policy(learner.policy_net, c.normalize_observations, c.normalize_latent)
  reset_key, z_key = jax.random.split(key)
  env_state = jax.vmap(env.reset)(jax.random.split(reset_key, c.num_eval_envs))
  z = jax.vmap(objective.sample_latent)(jax.random.split(z_key, c.num_eval_envs))

  def act(obs, key):  # the mean action, or as the original, a sampled one (``eval_actions``)
    return policy(params, obs, z if objective.conditions_policy else None, key=key,
                  deterministic=c.eval_actions == "mean")

  def record(state, action, next_state):
    transition = Transition(state.obs, action, next_state.obs, next_state.reward, z)
    reward = jax.vmap(objective.reward, (None, 0))(params.objective, transition)
    step = {"eval/episode_reward": reward, "eval/episode_env_reward": next_state.reward,
            "eval/episode_length": jnp.ones_like(next_state.done) * learner.action_repeat,
            **{f"eval/episode_{k}": v for k, v in next_state.metrics.items()}}
    return step, next_state.done

  def score(records):
    per_step, done = records
    alive = envs_lib.alive_before(done)  # [T, N]: a step counts until its episode has ended

    def total(x):  # the mean episode total: a scalar, or one per agent
      return jnp.mean(jnp.sum(alive.reshape(alive.shape + (1,) * (x.ndim - 2)) * x, axis=0),
                      axis=0)
    out = jax.tree.map(total, per_step)
    for key_ in [k for k, v in out.items() if v.ndim]:  # MAPPO: per-agent totals and their sum
      per_agent = out.pop(key_)
      out.update({f"{key_}/{a}": per_agent[i] for i, a in enumerate(learner.agent_names)})
      out[key_] = per_agent.sum()
    return out

  return envs_lib.Episodes(env, env_state, act, record, jax.random.fold_in(key, 2), steps), score


def run_chunks(config: PPOConfig, action_repeat: int = 1) -> tuple[int, int]:
  """The chunks of a run of ``config`` on an env of ``action_repeat``, and the iterations of each
  (``Trainer.num_chunks``, ``Trainer.iterations_per_chunk``): the iterations that reach
  ``num_timesteps`` (rounded up), in ``num_evals`` chunks (fewer where there are fewer
  iterations), each of them rounded up."""
  iterations = -(-config.num_timesteps // (config.env_steps_per_iteration * action_repeat))
  num_chunks = min(config.num_evals, iterations)
  return num_chunks, -(-iterations // num_chunks)


def make_trainer(env: Any, objective: Objective, config: PPOConfig) -> Trainer:
  """Binds the pieces above into the pure training functions for ``env``, run as given: its
  episode length and action repeat are its own (``blx.envs.create``); training adds auto-reset."""
  if not isinstance(config, PPOConfig):
    raise ValueError(f"config must be a PPOConfig, got {type(config).__name__}")
  if not isinstance(objective, Objective):
    raise ValueError(f"objective must be a blx.objectives.Objective, got {type(objective).__name__}")
  c = config
  base = envs_lib.unwrap(env)
  eval_steps = envs_lib.episode_steps(env, "make_trainer")
  repeat = getattr(env, "action_repeat", 1)
  train_env = envs_lib.auto_reset(env)
  eval_env = env

  obs_size = base.observation_size
  agents = getattr(base, "agents", None)
  learner = make_learner(obs_size, base.action_size, objective, c, repeat, agents)
  if agents is not None:
    _check_per_agent_reward(objective, obs_size, base.action_size, agents.names)
  policy_in = obs_size + (objective.latent_size if objective.conditions_policy else 0)
  shard = _data_sharding(c.num_envs)

  num_chunks, iterations_per_chunk = run_chunks(c, repeat)

  def init(key: jax.Array) -> TrainState:
    policy_key, value_key, obj_key, env_key, z_key, key = jax.random.split(key, 6)
    params = Params(
        policy=learner.policy_net.init(policy_key, jnp.zeros((policy_in,))),
        value=learner.value_net.init(value_key, jnp.zeros((policy_in,))),
        objective=objective.init(obj_key, obs_size))
    env_state = jax.vmap(train_env.reset)(jax.random.split(env_key, c.num_envs))
    if c.starts_staggered:
      env_state = stagger(env_state, jax.random.fold_in(env_key, 1))
    z = jax.vmap(objective.sample_latent)(jax.random.split(z_key, c.num_envs))
    return TrainState(params=params, opt_state=learner.optimizer.init(params),
                      normalizer=networks.init_stats(learner.stats_size),
                      env_state=shard(env_state), z=shard(z), key=key,
                      env_steps=jnp.zeros((), jnp.float32), iteration=jnp.zeros((), jnp.int32))

  def stagger(env_state, key):
    # The episode clock counts steps of the unrepeated env, so offsets are whole policy steps.
    steps = env_state.info["steps"]
    offsets = jax.random.randint(key, steps.shape, 0, eval_steps) * repeat
    return env_state.replace(info={**env_state.info, "steps": offsets.astype(steps.dtype)})

  def collect_fn(state: TrainState) -> tuple[TrainState, Rollout]:
    return collect(learner, train_env, state, shard)

  def update_fn(state: TrainState, data: Rollout) -> tuple[TrainState, dict]:
    return update(learner, state, data)

  def iteration(state: TrainState, _):
    with jax.named_scope("collect"):
      state, data = collect_fn(state)
    with jax.named_scope("update"):
      return update_fn(state, data)

  def chunk(state: TrainState, length: int = iterations_per_chunk):
    return jax.lax.scan(iteration, state, None, length=length)

  def evaluate_fn(params: PolicyParams, key: jax.Array) -> dict:
    return evaluate(learner, eval_env, eval_steps, params, key)

  def evaluation_episodes_fn(params: PolicyParams, key: jax.Array):
    return evaluation_episodes(learner, eval_env, eval_steps, params, key)

  def train(key: jax.Array):
    init_key, eval_key = jax.random.split(key)
    state = init(init_key)

    def one_chunk(state, key):
      state, metrics = chunk(state)
      metrics = jax.tree.map(lambda x: x.mean(0) if x.dtype != bool else x.any(0), metrics)
      return state, {**metrics, **evaluate_fn(policy_params(state), key)}

    return jax.lax.scan(one_chunk, state, jax.random.split(eval_key, num_chunks))

  policy = make_policy(learner.policy_net, c.normalize_observations, c.normalize_latent)
  return Trainer(init=init, chunk=chunk, collect=collect_fn, update=update_fn,
                 evaluate=evaluate_fn, evaluation_episodes=evaluation_episodes_fn, train=train,
                 policy=policy, num_chunks=num_chunks, iterations_per_chunk=iterations_per_chunk,
                 config=c, env_steps_per_iteration=c.env_steps_per_iteration * repeat)


def _check_per_agent_reward(objective: Objective, obs_size: int, action_size: int,
                            agents: tuple[str, ...]) -> None:
  """MAPPO needs one reward per agent from the objective, following the env's per-agent rewards
  (``task`` passes them through). An objective that gives every agent the same reward whatever
  the env's (e.g. DIAYN without ``env_reward_multiplier``) is refused."""
  params = objective.init(jax.random.PRNGKey(0), obs_size)

  def reward(env_reward):
    t = Transition(jnp.zeros(obs_size), jnp.zeros(action_size), jnp.zeros(obs_size), env_reward,
                   jnp.zeros(objective.latent_size))
    return jnp.asarray(objective.reward(params, t))
  base = reward(jnp.zeros(len(agents)))
  moved = reward(jnp.arange(1.0, len(agents) + 1.0)) - base
  per_agent = base.shape == (len(agents),)
  if not per_agent or bool(jnp.allclose(moved, moved.reshape(-1)[0])):
    gives = "every agent the same reward" if per_agent else f"a reward of shape {base.shape}"
    raise ValueError(f"make_trainer: the env is multi-agent (agents {list(agents)}), so MAPPO needs "
                     f"one reward per agent that follows the env's, but objective "
                     f"{objective.name!r} gives {gives}; use the task objective, or give a "
                     "reward-free objective to one agent with "
                     "blx.objectives.for_agent(objective, agent=i, num_agents=n)")


def policy_params(state: TrainState) -> PolicyParams:
  """The parameters a trained policy acts and is evaluated with."""
  return PolicyParams(normalizer=state.normalizer, policy=state.params.policy,
                      objective=state.params.objective)


def make_train(env: Any, objective: Objective, config: PPOConfig) -> Callable:
  """``train(key) -> (TrainState, metrics)``: the whole run as one pure function."""
  return make_trainer(env, objective, config).train
