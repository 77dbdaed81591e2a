"""The ``Objective`` interface: what the trainer needs from a reward-free (or task) objective.

An objective is a NamedTuple of pure functions (the optax ``GradientTransformation`` pattern). The
trainer carries its parameters in the training state, calls ``reward`` during rollouts, appends the
latent ``z`` to the policy's input when ``conditions_policy`` is set, and adds ``loss`` to the PPO
loss in the same SGD step. It never looks inside.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp

from blx.objectives.specs import Spec, TaskSpec

__all__ = ["Transition", "Objective", "task", "for_agent"]

Params = Any


class Transition(NamedTuple):
  """One environment step, as the objective sees it (unbatched: ``[O]``, ``[A]``, ``[]``, ``[Z]``).

  Attributes:
    obs: s_t, the raw (unnormalised) observation the action was taken in.
    action: a_t in [-1, 1].
    next_obs: s_{t+1}, the raw observation after the step (before any auto-reset).
    env_reward: the environment's task reward r_t.
    z: the latent the policy was conditioned on (empty ``[0]`` when none).
  """

  obs: jax.Array
  action: jax.Array
  next_obs: jax.Array
  env_reward: jax.Array
  z: jax.Array


class Objective(NamedTuple):
  """A training objective: pure functions plus the static facts the trainer needs.

  Attributes:
    init: ``(key, obs_size) -> params`` (a pytree; ``{}`` for none).
    sample_latent: ``key -> z [latent_size]``, drawn once per parallel env.
    reward: ``(params, Transition) -> r []`` for one transition; the trainer stops its gradient.
    loss: ``(params, Transition [N, ...], key) -> (scalar, metrics)`` on a batch of transitions.
    latent_size: size of z (0 when the objective has no latent).
    conditions_policy: whether the policy sees z.
    name: a short label for logs.
    post_update: optional ``(params, Transition [N, ...]) -> params``, applied after every SGD step
      to state that is not learned by gradient (spectral-norm power iterations, running statistics
      of observations). None: nothing to do.
    spec: what evaluation, plots and the command line may know about the objective, typed by
      family (``blx.objectives.specs``: ``MimaxSpec``, ``DminSpec``, ``TaskSpec``); never read by
      the trainer.
  """

  init: Callable[[jax.Array, int], Params]
  sample_latent: Callable[[jax.Array], jax.Array]
  reward: Callable[[Params, Transition], jax.Array]
  loss: Callable[[Params, Transition, jax.Array], tuple[jax.Array, dict[str, jax.Array]]]
  latent_size: int = 0
  conditions_policy: bool = False
  name: str = "objective"
  post_update: Callable[[Params, Transition], Params] | None = None
  spec: Spec = TaskSpec()


def task() -> Objective:
  """Plain reward maximisation: the reward is the environment's, nothing is learned besides PPO."""
  return Objective(
      init=lambda key, obs_size: {},
      sample_latent=lambda key: jnp.zeros((0,)),
      reward=lambda params, t: t.env_reward,
      loss=lambda params, batch, key: (jnp.zeros(()), {}),
      latent_size=0,
      conditions_policy=False,
      name="task",
      spec=TaskSpec(),
  )


def for_agent(objective: Objective, agent: int, num_agents: int) -> Objective:
  """``objective`` for agent ``agent`` of a multi-agent env, the others keeping their env rewards.

  The reward becomes a vector ``[num_agents]``: the env's per-agent rewards, with entry ``agent``
  replaced by ``objective``'s reward computed on that agent's env reward (so an objective's
  ``env_reward_multiplier`` mixes in the agent's own task reward). Everything else (latent,
  discriminator loss, spec) is ``objective``'s: the latent conditions every agent's policy, since
  all agents see the same observation, but only ``agent`` is paid for it. MAPPO trains it like
  ``task``. On the command line: ``blx train --env ENV --objective NAME --agent AGENT``.
  """
  if isinstance(num_agents, bool) or not isinstance(num_agents, int) or num_agents < 2:
    raise ValueError(f"for_agent: num_agents must be an int >= 2, got {num_agents!r}")
  if isinstance(agent, bool) or not isinstance(agent, int) or not 0 <= agent < num_agents:
    raise ValueError(f"for_agent: agent must be an index in 0..{num_agents - 1}, got {agent!r}")

  def reward(params, t: Transition) -> jax.Array:
    env_reward = jnp.asarray(t.env_reward)
    if env_reward.shape != (num_agents,):
      raise ValueError(f"for_agent: the env's reward has shape {env_reward.shape}, not "
                       f"({num_agents},): is the env multi-agent with {num_agents} agents?")
    own = objective.reward(params, t._replace(env_reward=env_reward[agent]))
    return env_reward.at[agent].set(own)

  return objective._replace(reward=reward, name=f"{objective.name}@agent{agent}")
