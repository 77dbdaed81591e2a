"""``PPOConfig`` and the per-environment defaults of the original Braxlines."""

from __future__ import annotations

import dataclasses
import math
import operator
from typing import Any, Mapping

from blx.options import check_names

__all__ = ["PPOConfig", "ppo_defaults", "check_seeds", "off_row", "off_row_text",
           "UNRECORDED_SETTINGS", "RETURN_SETTINGS"]

MAX_INT = 2**31 - 1  # step and iteration counters are 32-bit on the device
# How the evaluation after each chunk acts (``PPOConfig.eval_actions``): blx's default first.
EVAL_ACTIONS = ("sampled", "mean")
ORIGINAL_NUM_ENVS = 2048  # Braxlines' num_envs in every row of its defaults


@dataclasses.dataclass(frozen=True)
class PPOConfig:
  """Static PPO settings (sizes and loop lengths; hashable, so jit can close over it).

  Per iteration, every one of ``num_envs`` envs is unrolled for ``unroll_length`` steps,
  ``batch_size * num_minibatches // num_envs`` times; the collected sequences are then used for
  ``num_updates_per_batch`` epochs of ``num_minibatches`` SGD steps on ``batch_size`` sequences.

  Both switches below default to Braxlines' PPO:

  * ``normalize_advantage``: standardise GAE advantages per minibatch (common in other PPOs; the
    original does not, so ``entropy_cost`` and ``reward_scaling`` keep their meaning there).
  * ``normalize_latent``: the policy's and value's input [obs, z] goes through the running
    normaliser as one vector, as the original (its z is appended to the observation by a wrapper).
    False: only obs is normalised and z is appended raw.

  ``staggered_starts``: at the start of training every env's episode clock is set to a random
  step in [0, episode length), so the envs' episodes end at different times instead of all
  together. Each env still starts from its reset state; only its first episode is cut short. With
  many envs and few steps per env (16,384 envs see 1,800 steps each in 30 M steps), synchronised
  envs fill every batch with one narrow phase of the episode. The default ``None`` chooses by
  ``num_envs``: off up to the original's 2,048 envs (so the paper's settings run as the original,
  whose envs all start together), on above them, where the original never ran and where staggered
  starts took DIAYN on Ant at 16,384 envs to the paper's MI (benchmarks/RESULTS.md, session 9).
  ``True`` or ``False`` forces it; ``starts_staggered`` is the resolved value.

  ``max_grad_norm`` (default ``None``, Braxlines' PPO: plain Adam): where set, each SGD step's
  gradient is scaled down to this global norm, over all the learner's parameters together
  (policy, value and an objective's discriminator), before Adam. An option, not the original's;
  the logged ``grad_norm`` is the norm before clipping, and ``grad_clipped`` the share of SGD
  steps the clip scaled down (logged only where it is set).

  ``checkpoint_env_state`` (default on): checkpoints hold the whole training state, so a resumed
  run continues exactly where it stopped. False leaves the envs' state out (the simulator state of
  every env: 47 of the 51 MB per seed of the Ant rows' 2,048 envs), so that a checkpoint can be
  carried to another machine. A run resumed from such a checkpoint starts every
  env on a new episode, reset as at the start of training; that is the one way it differs from an
  uninterrupted run.

  ``eval_actions``: how the ``num_eval_envs`` episodes of the evaluation after each chunk
  (``eval/episode_reward``, ``eval/episode_score``, ...) act. ``"sampled"`` (the default, the
  original's) samples the actions, as Braxlines' PPO does (its evaluation on 128 envs samples from
  the policy, braxlines/training/ppo.py at the paper's commit), so that the evaluation averages
  over the policy's episodes. ``"mean"`` (an option; blx's default until session 61, and so what
  every run before then took) takes the policy's mean action: where the env's reset has no noise
  and the objective no latent (a Composer task such as ``pro_ant_run``) every episode is then the
  same episode, one trajectory per seed. The paper's metrics (MI, LGR, energy distance) have
  evaluators of their own, which sample as the paper's, whichever this is. A setting of the
  evaluation, not of learning; a resumed run keeps the one it began with, also where blx's
  default moved after (``training.config_as_trained``; a checkpoint that does not record it took
  ``UNRECORDED_SETTINGS``' mean action).
  """

  num_timesteps: int = 30_000_000
  num_envs: int = 2048
  unroll_length: int = 5
  batch_size: int = 1024
  num_minibatches: int = 32
  num_updates_per_batch: int = 4
  learning_rate: float = 3e-4
  entropy_cost: float = 1e-2
  discounting: float = 0.97
  gae_lambda: float = 0.95
  clipping_epsilon: float = 0.3
  reward_scaling: float = 10.0
  normalize_observations: bool = True
  normalize_advantage: bool = False
  normalize_latent: bool = True
  staggered_starts: bool | None = None
  checkpoint_env_state: bool = True
  max_grad_norm: float | None = None
  policy_hidden: tuple[int, ...] = (32, 32, 32, 32)
  value_hidden: tuple[int, ...] = (256, 256, 256, 256, 256)
  num_evals: int = 20
  num_eval_envs: int = 128
  eval_actions: str = "sampled"

  def __post_init__(self):
    positive = ("num_timesteps", "num_envs", "unroll_length",
                "batch_size", "num_minibatches", "num_updates_per_batch", "num_evals",
                "num_eval_envs")
    for name in positive:
      value = getattr(self, name)
      if not isinstance(value, int) or isinstance(value, bool) or not 1 <= value <= MAX_INT:
        raise ValueError(f"PPOConfig.{name} must be a positive int up to 2**31 - 1, got {value!r}")
    real = lambda v: isinstance(v, (int, float)) and not isinstance(v, bool)
    for name in ("learning_rate", "entropy_cost", "discounting", "gae_lambda", "clipping_epsilon",
                 "reward_scaling"):
      if not real(getattr(self, name)):
        raise ValueError(f"PPOConfig.{name} must be a number, got {getattr(self, name)!r}")
      if not math.isfinite(getattr(self, name)):
        raise ValueError(f"PPOConfig.{name} must be finite, got {getattr(self, name)!r}")
    if self.entropy_cost < 0 or self.reward_scaling <= 0:
      raise ValueError(f"PPOConfig: entropy_cost must be >= 0 and reward_scaling > 0, got "
                       f"{self.entropy_cost!r} and {self.reward_scaling!r}")
    if not (self.max_grad_norm is None or (real(self.max_grad_norm) and self.max_grad_norm > 0
                                           and math.isfinite(self.max_grad_norm))):
      raise ValueError(f"PPOConfig.max_grad_norm must be None or a positive number, got "
                       f"{self.max_grad_norm!r}")
    for name in ("normalize_observations", "normalize_advantage", "normalize_latent",
                 "checkpoint_env_state"):
      if not isinstance(getattr(self, name), bool):
        raise ValueError(f"PPOConfig.{name} must be True or False, got {getattr(self, name)!r}")
    if self.eval_actions not in EVAL_ACTIONS:
      valid = ", ".join(map(repr, EVAL_ACTIONS))
      raise ValueError(f"PPOConfig.eval_actions must be one of {valid} (sampled actions, the "
                       f"original's and blx's default, or the mean action), got "
                       f"{self.eval_actions!r}")
    if not (self.staggered_starts is None or isinstance(self.staggered_starts, bool)):
      raise ValueError(f"PPOConfig.staggered_starts must be True, False or None (chosen by "
                       f"num_envs), got {self.staggered_starts!r}")
    if (self.batch_size * self.num_minibatches) % self.num_envs:
      raise ValueError(
          f"PPOConfig: batch_size * num_minibatches ({self.batch_size * self.num_minibatches}) must "
          f"be a multiple of num_envs ({self.num_envs})")
    for name in ("discounting", "gae_lambda"):
      if not 0.0 <= getattr(self, name) <= 1.0:
        raise ValueError(f"PPOConfig.{name} must lie in [0, 1], got {getattr(self, name)!r}")
    if self.learning_rate <= 0 or self.clipping_epsilon <= 0:
      raise ValueError("PPOConfig: learning_rate and clipping_epsilon must be positive")
    for name in ("policy_hidden", "value_hidden"):
      value = getattr(self, name)
      if (not isinstance(value, (tuple, list)) or not value
          or not all(isinstance(v, int) and v > 0 for v in value)):
        raise ValueError(f"PPOConfig.{name} must be a non-empty sequence of positive ints, e.g. "
                         f"(32, 32), got {value!r}")
      object.__setattr__(self, name, tuple(value))

  @property
  def starts_staggered(self) -> bool:
    """``staggered_starts`` resolved: where it is None, whether ``num_envs`` exceeds the original's
    2,048."""
    if self.staggered_starts is None:
      return self.num_envs > ORIGINAL_NUM_ENVS
    return self.staggered_starts

  @property
  def num_unrolls(self) -> int:
    """Unrolls per env per iteration."""
    return self.batch_size * self.num_minibatches // self.num_envs

  @property
  def env_steps_per_iteration(self) -> int:
    """Policy steps per iteration; env steps at action repeat 1 (a ``Trainer``'s
    ``env_steps_per_iteration`` counts the env's repeats)."""
    return self.num_envs * self.unroll_length * self.num_unrolls

  def replace(self, **changes: Any) -> "PPOConfig":
    check_env_owned("PPOConfig", changes)
    check_names("PPOConfig", changes, [f.name for f in dataclasses.fields(self)], "key")
    return dataclasses.replace(self, **changes)


# Settings of the episode, which the env owns (blx.envs.create(..., episode_length=,
# action_repeat=)); PPOConfig had them before.
ENV_OWNED = ("episode_length", "action_repeat", "eval_episode_length")


def check_env_owned(where: str, names: Any) -> None:
  """A clear error for an episode setting given as a PPO setting."""
  given = [n for n in ENV_OWNED if n in names]
  if given:
    raise ValueError(f"{where}: {', '.join(given)} belong to the env, not to PPO: create the env "
                     "with them (blx.envs.create(name, episode_length=..., action_repeat=...); "
                     "CLI: --env-param episode_length=...); the trainer, evaluations and render "
                     "run the env as given")


def check_seeds(seeds: Any, where: str = "seeds") -> tuple[int, ...]:
  """The seeds of one vmapped run as a tuple: a non-empty sequence of distinct ints in 0..2**31 - 1
  (one run per seed; a seed is a PRNG key's 32-bit value). Anything else raises ``ValueError``."""
  if isinstance(seeds, (str, bytes)) or not hasattr(seeds, "__len__") or not len(seeds):
    raise ValueError(f"{where}: expected a non-empty list of ints such as [0, 1, 2], got {seeds!r}")
  seeds = list(seeds)

  def as_seed(s):
    if isinstance(s, bool):  # operator.index takes True as 1
      return None
    try:
      value = operator.index(s)  # ints, numpy and jax integer scalars
    except TypeError:
      return None
    return value if 0 <= value <= MAX_INT else None

  values = [as_seed(s) for s in seeds]
  bad = [s for s, v in zip(seeds, values) if v is None]
  if bad:
    raise ValueError(f"{where}: {bad} are not seeds; seeds are ints in 0..2**31 - 1")
  if len(set(values)) != len(values):
    raise ValueError(f"{where}: {values} repeats a seed; each seed is one run, so seeds are distinct")
  return tuple(values)


# Braxlines experiments/defaults.py (all: normalised observations, lr 3e-4, 2048 envs, 32
# minibatches; the episodes of 1000 steps are the envs' own, see blx.envs.create). Composer envs and
# unknown names use the ant row.
_ROWS: dict[str, dict[str, Any]] = {
    "ant": dict(num_timesteps=30_000_000, reward_scaling=10.0, unroll_length=5,
                num_updates_per_batch=4, discounting=0.97, entropy_cost=1e-2, batch_size=1024,
                num_evals=20),
    "humanoid": dict(num_timesteps=50_000_000, reward_scaling=0.1, unroll_length=10,
                     num_updates_per_batch=8, discounting=0.97, entropy_cost=1e-3, batch_size=1024,
                     num_evals=20),
    "halfcheetah": dict(num_timesteps=100_000_000, reward_scaling=1.0, unroll_length=20,
                        num_updates_per_batch=8, discounting=0.95, entropy_cost=1e-3,
                        batch_size=512, num_evals=10),
    # Not in Braxlines: a small row for the point mass (whose env has 50-step episodes), so runs
    # finish in a minute on 2 CPU cores.
    "point": dict(num_timesteps=200_000, num_envs=64, unroll_length=10,
                  batch_size=64, num_minibatches=4, num_updates_per_batch=4, learning_rate=3e-3,
                  entropy_cost=1e-3, discounting=0.95, reward_scaling=1.0, num_evals=4,
                  num_eval_envs=16),
}


def ppo_defaults(env_name: str | None = None, **overrides: Any) -> PPOConfig:
  """The PPO row for ``env_name`` (ant, humanoid, halfcheetah, point; anything else: ant).

  Envs named after a body (``humanoid_run``) take that body's row; ``overrides`` replace fields.
  """
  name = env_name or "ant"
  row = None
  for key in ("point", "humanoid", "halfcheetah", "ant"):
    if name == key or name.startswith(key + "_"):
      row = _ROWS[key]
      break
  return PPOConfig(**(row or _ROWS["ant"])).replace(**overrides)


# PPO settings that set a run's length and bookkeeping, not how it learns: ``off_row`` leaves them
# out. ``eval_actions`` is not among them: it changes what the return episodes' curves measure,
# so a run evaluated with the mean action, not as the original, says so wherever those are
# reported (``RETURN_SETTINGS`` below).
BOOKKEEPING = ("num_timesteps", "num_evals", "num_eval_envs", "checkpoint_env_state")
# Settings of the return episodes alone (the evaluation after each chunk: ``eval/episode_*``). The
# paper's metrics (MI, H(s), LGR, energy distance) have evaluators of their own, so a report of
# those, or an analysis that rolls out its own episodes, leaves these out (``off_row``'s
# ``returns=False``).
RETURN_SETTINGS = ("eval_actions",)

# The settings every run trained with that records none of its own (its provenance.json's
# segments written before session 60, which did not yet hold ``Segment.ppo``), whatever blx's
# defaults are now: where a default of PPOConfig moves, its value before the move goes here, so
# that a report still names such a run's setting beside a row under the new default
# (``runs.settings_as_trained``), and a checkpoint that does not record it resumes and is
# evaluated with it (``loop.config_as_trained``). eval_actions: the default moved from the mean
# action to the original's sampled ones in session 61; every run before took the mean action.
UNRECORDED_SETTINGS: dict[str, Any] = {"eval_actions": "mean"}


def off_row(env_name: str | None, ppo: Mapping[str, Any] | None, *,
            returns: bool = True) -> dict[str, tuple]:
  """The settings of ``ppo`` (``PPOConfig`` field -> value, as a run's ``config.json`` holds them)
  that differ from ``env_name``'s row (``ppo_defaults``; for Ant, Humanoid and HalfCheetah the
  original's), ``{field: (the run's value, the row's)}`` in field order, the run's length and
  bookkeeping (``BOOKKEEPING``) left out: a run with any learned under an option. ``returns``:
  whether what is reported includes the return episodes (``eval/episode_*``); False leaves out
  the settings of those alone (``RETURN_SETTINGS``: eval_actions)."""
  row = dataclasses.asdict(ppo_defaults(env_name))
  left_out = BOOKKEEPING + (() if returns else RETURN_SETTINGS)
  return {key: (value, row[key]) for key, value in sorted((ppo or {}).items())
          if key not in left_out and key in row
          and (tuple(value) if isinstance(value, list) else value) != row[key]}


def off_row_text(env_name: str | None, ppo: Mapping[str, Any] | None, *,
                 returns: bool = True) -> str:
  """``off_row`` for a figure's title or a label: "PPO max_grad_norm 5 (default None)", the
  settings joined by commas, or "" where the run has none."""
  changed = off_row(env_name, ppo, returns=returns)
  return ("PPO " + ", ".join(f"{key} {value} (default {row})"
                             for key, (value, row) in changed.items()) if changed else "")
