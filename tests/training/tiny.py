"""A tiny objective defined for the trainer's tests (the trainer knows no objective but ``task``)."""

import jax.numpy as jnp

from blx.objectives import Objective
from blx.training import PPOConfig

GOAL = jnp.array([2.0, -1.0])


def reach_latent(poison: bool = False) -> Objective:
  """Reward: -||p_xy - z|| with a fixed latent z = (2, -1) that the policy sees.

  Its one parameter w is pulled to 1 by its loss (w - 1)^2, optimised in PPO's SGD step. With
  ``poison`` the loss is NaN.
  """
  def loss(params, batch, key):
    value = (params["w"] - 1.0) ** 2 + (jnp.nan if poison else 0.0)
    return value, {"loss/tiny": value, "tiny/mean_obs": batch.next_obs.mean()}

  return Objective(
      init=lambda key, obs_size: {"w": jnp.zeros(())},
      sample_latent=lambda key: GOAL,
      reward=lambda params, t: -jnp.linalg.norm(t.next_obs[:2] - t.z),
      loss=loss,
      latent_size=2,
      conditions_policy=True,
      name="tiny",
  )


# Small enough to compile and run in seconds on CPU.
SMALL = PPOConfig(num_timesteps=2 * 16 * 5 * 2, num_envs=16, unroll_length=5,
                  batch_size=8, num_minibatches=4, num_updates_per_batch=2, learning_rate=1e-3,
                  reward_scaling=1.0, num_evals=2, num_eval_envs=4, policy_hidden=(16, 16),
                  value_hidden=(16, 16))
