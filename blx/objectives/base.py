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

__all__ = ["Transition", "Objective", "task"]

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
