"""The one dispatch from an objective's spec to how it is evaluated, tabulated and plotted.

Runs, sweeps, plots and the command line ask this module; none of them switches on a family's
name. A new objective family registers here once::

    metrics.register_family(MySpec, metrics.Family(
        name="mine", make_evaluator=my_evaluator_factory,
        table=(("my metric", "eval/my_metric", 1.0),), plot=None))
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

from blx import envs
from blx.metrics.evaluate import dmin_evaluator, mimax_evaluator
from blx.objectives.base import Objective
from blx.objectives.specs import DminSpec, MimaxSpec, TaskSpec

__all__ = ["Family", "register_family", "family_of", "evaluator_for", "scored_steps", "PLOTS"]

# What ``blx.experiments.plots`` can draw for a family beyond the training curves: "skills" (the
# feature space per latent, for specs with a prior) and "density" (policy samples against the
# target, for specs with a target).
PLOTS = ("skills", "density")


class Family(NamedTuple):
  """How runs of one spec type are measured.

  Attributes:
    name: the label that groups runs in sweep tables ("mimax", "dmin", "task").
    make_evaluator: ``(env, objective, *, last_steps, quick) -> (policy, params, key) -> metrics``
      (``env`` as given, with its episode length), or None when the family has no metric beyond
      rewards.
    table: the columns of the paper-style table: ``(label, metric key, sign)``; the sign turns
      metrics where smaller is better into the paper's "-LGR" style.
    plot: one of ``PLOTS`` or None.
  """

  name: str
  make_evaluator: Callable[..., Callable] | None
  table: tuple[tuple[str, str, float], ...]
  plot: str | None = None


_FAMILIES: dict[type, Family] = {}


def register_family(spec_type: type, family: Family) -> None:
  """Registers how objectives whose ``spec`` is a ``spec_type`` are evaluated (fails if taken)."""
  if not isinstance(spec_type, type):
    raise ValueError(f"register_family: spec_type must be a class, got {spec_type!r}")
  if spec_type in _FAMILIES:
    raise ValueError(f"register_family: {spec_type.__name__} is already registered")
  if not isinstance(family, Family):
    raise ValueError(f"register_family: expected a blx.metrics.Family, got {type(family).__name__}")
  if family.plot is not None and family.plot not in PLOTS:
    raise ValueError(f"register_family: plot={family.plot!r} is not valid; valid plots are "
                     f"{list(PLOTS)} or None")
  _FAMILIES[spec_type] = family


def family_of(objective: Objective) -> Family:
  """The registered family of ``objective.spec``'s type."""
  family = _FAMILIES.get(type(objective.spec))
  if family is None:
    raise ValueError(f"objective {objective.name!r}: no evaluation is registered for its spec type "
                     f"{type(objective.spec).__name__}; registered spec types are "
                     f"{sorted(t.__name__ for t in _FAMILIES)} (blx.metrics.register_family)")
  return family


def evaluator_for(env: Any, objective: Objective, *, quick: bool = False) -> Callable | None:
  """The paper's evaluator for ``objective`` (None when its family has none), on the last half of
  each of ``env``'s episodes (at most 500 steps, the paper's); ``quick`` uses fewer rollouts (for
  logging while training)."""
  family = family_of(objective)
  if family.make_evaluator is None:
    return None
  return family.make_evaluator(env, objective, last_steps=scored_steps(env), quick=quick)


def scored_steps(env: Any) -> int:
  """How many of the last steps of each of ``env``'s episodes the paper's evaluators score: half
  the episode, at most 500 (the paper's, for its 1,000-step episodes)."""
  return min(500, max(1, envs.episode_steps(env, "evaluator_for") // 2))


# Rollouts per evaluation by protocol (``blx.experiments.runs.EVAL_PROTOCOLS``): MI-max's latents,
# episodes per latent and LGR goals, D-min's episodes; "quick" while training, "final": eval.json.
ROLLOUTS = {"quick": 4, "final": 10}


def _mimax(env, objective, *, last_steps, quick):
  n = ROLLOUTS["quick" if quick else "final"]
  return mimax_evaluator(env, objective, num_latents=n, episodes_per_latent=n, num_goals=n,
                         last_steps=last_steps)


def _dmin(env, objective, *, last_steps, quick):
  steps = envs.episode_steps(env, "evaluator_for")
  return dmin_evaluator(env, objective, num_episodes=ROLLOUTS["quick" if quick else "final"],
                        every=1 if steps < 200 else 10, last_steps=last_steps)


register_family(MimaxSpec, Family(
    name="mimax", make_evaluator=_mimax, plot="skills",
    table=(("MI(s,z)", "eval/mi", 1.0), ("H(s)", "eval/entropy", 1.0), ("-LGR", "eval/lgr", -1.0),
           ("coverage", "eval/coverage", 1.0))))
register_family(DminSpec, Family(
    name="dmin", make_evaluator=_dmin, plot="density",
    table=(("-energy distance", "eval/energy_distance", -1.0),)))
# A task's reward and score sum per-step terms over the episode, so an episode that ends early (a
# body that falls) sums fewer of them: its length is tabulated beside them.
register_family(TaskSpec, Family(
    name="task", make_evaluator=None,
    table=(("episode reward", "eval/episode_reward", 1.0),
           ("episode score", "eval/episode_score", 1.0),
           ("episode length", "eval/episode_length", 1.0))))
