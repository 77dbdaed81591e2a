"""blx.objectives — reward-free objectives as stateless functions, assembled into presets."""

from blx.objectives.base import Objective, Transition, task

__all__ = ["Objective", "Transition", "task"]
