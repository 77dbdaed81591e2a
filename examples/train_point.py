"""The main job until the `blx` command lands: PPO on the point mass reaching a goal, 3 seeds vmapped.

    python examples/train_point.py
"""

import numpy as np

from blx import envs, training
from blx.objectives import task

env = envs.create("point_goal")
config = training.ppo_defaults("point", num_timesteps=100_000)
result = training.train(env, task(), config, seeds=(0, 1, 2))
rewards = result.metrics[-1]["eval/episode_reward"]
print(f"eval episode reward per seed: {np.round(rewards, 1).tolist()} "
      f"(an untrained policy scores about -150)")
