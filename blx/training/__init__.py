"""blx.training — one PPO: pure train step (jit, vmap over seeds, sharded) and its host loop."""

from blx.training.config import PPOConfig, check_seeds, ppo_defaults
from blx.training.loop import (NonFiniteError, SegmentDone, TimeLimitReached, TrainResult,
                               checkpoint_env_steps, checkpoint_finished, checkpoint_progress,
                               config_as_trained, drop_env_state, evaluate_together,
                               print_progress, print_segment, restore_state, segment_length,
                               stop_time, train)
from blx.training.losses import clipped_surrogate, gae
from blx.training.ppo import (RETURN_KEYS, Params, PolicyParams, Trainer, TrainState, make_policy,
                              make_train, make_trainer, place_state, policy_params, run_chunks)

__all__ = ["RETURN_KEYS", "PPOConfig", "ppo_defaults", "check_seeds", "NonFiniteError",
           "TimeLimitReached", "stop_time",
           "TrainResult", "SegmentDone", "train", "evaluate_together", "print_progress",
           "print_segment", "restore_state",
           "drop_env_state", "segment_length", "checkpoint_finished", "checkpoint_progress",
           "checkpoint_env_steps", "config_as_trained", "clipped_surrogate", "gae", "Params",
           "PolicyParams", "policy_params",
           "Trainer", "TrainState", "make_policy", "make_train", "make_trainer", "place_state",
           "run_chunks"]
