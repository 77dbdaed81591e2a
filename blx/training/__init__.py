"""blx.training — one PPO: pure train step (jit, vmap over seeds, sharded) and its host loop."""

from blx.training.config import PPOConfig, ppo_defaults
from blx.training.loop import NonFiniteError, TrainResult, train
from blx.training.losses import clipped_surrogate, gae
from blx.training.ppo import Params, Trainer, TrainState, make_policy, make_train, make_trainer

__all__ = ["PPOConfig", "ppo_defaults", "NonFiniteError", "TrainResult", "train",
           "clipped_surrogate", "gae", "Params", "Trainer", "TrainState", "make_policy",
           "make_train", "make_trainer"]
