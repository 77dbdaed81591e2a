"""blx.envs — the Composer: environments as descs, built as MJCF strings, stepped on MJX."""

from blx.envs import descs as _descs  # noqa: F401  (registers the built-in envs)
from blx.envs.agents import AgentGroups
from blx.envs.components import ComponentSpec, Termination, list_components, register_component
from blx.envs.composer import GLOBAL_OPTIONS, Scene, apply_edits, compose
from blx.envs.env import Env, State
from blx.envs.registry import create, env_params, get_desc, list_envs, register_env
from blx.envs.rollout import Episodes, alive_before, rollout, rollout_together
from blx.envs.wrappers import (action_repeat, auto_reset, episode, episode_steps, resets_itself,
                               unwrap)

__all__ = [
    "AgentGroups",
    "ComponentSpec", "Termination", "list_components", "register_component",
    "GLOBAL_OPTIONS", "Scene", "apply_edits", "compose",
    "Env", "State",
    "create", "env_params", "get_desc", "list_envs", "register_env",
    "action_repeat", "auto_reset", "episode", "episode_steps", "resets_itself", "unwrap",
    "rollout", "alive_before", "Episodes", "rollout_together",
]
