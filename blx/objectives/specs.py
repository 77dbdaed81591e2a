"""What other packages may know about an objective: one typed spec per family.

The trainer never reads a spec (it needs only the ``Objective``'s functions). Evaluation, plots,
rendering and the command line do, through ``Objective.spec``; ``blx.metrics`` owns the one
dispatch from a spec's type to its evaluator. A new family is a new spec type here plus one
``blx.metrics.register_family`` call.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

from blx.objectives.priors import Prior
from blx.objectives.targets import Target

__all__ = ["MimaxSpec", "DminSpec", "TaskSpec", "Spec"]


class MimaxSpec(NamedTuple):
  """A mutual-information objective: skills z ~ prior, posterior q(z | s[obs_indices]).

  Attributes:
    prior: p(z); its ``kind`` is "categorical", "uniform" or "deterministic".
    obs_indices: the observation dimensions the posterior reads (None: all of them).
    eval_indices: the dimensions evaluation, plots and LGR look at (the paper's feature space).
    obs_scale: the half-width of the evaluation histograms and of the LGR goal box.
    offset: the constant added to log q to keep rewards non-negative.
    posterior: "identity" (q = N(s_idx, I)), "gaussian" (a learned mean) or "categorical".
    posterior_out: ``(params, obs [O]) -> [Z]`` the Gaussian mean or the logits.
    infer_latent: ``(params, obs [O]) -> z [Z]``, the skill that best explains ``obs``.
    log_q: ``(params, obs [O], z [Z]) -> []``.
  """

  prior: Prior
  obs_indices: tuple[int, ...] | None
  eval_indices: tuple[int, ...] | None
  obs_scale: float
  offset: float
  posterior: str
  posterior_out: Callable[[Any, Any], Any]
  infer_latent: Callable[[Any, Any], Any]
  log_q: Callable[[Any, Any, Any], Any]

  @property
  def num_skills(self) -> int | None:
    """K for a categorical prior, else None."""
    return self.prior.dim if self.prior.kind == "categorical" else None


class DminSpec(NamedTuple):
  """A state-marginal-matching objective: match the policy's s[obs_indices] to ``target``.

  Attributes:
    obs_indices: the observation dimensions matched (and shown in plots).
    obs_scale: the half-width of plots of the feature space.
    target: the target distribution (samples, and a density when known).
    include_action: whether the discriminator also sees the action.
    logit: ``(params, x [D]) -> []`` the clipped discriminator logit, or None (MLE: no
      discriminator).
  """

  obs_indices: tuple[int, ...]
  obs_scale: float
  target: Target
  include_action: bool
  logit: Callable[[Any, Any], Any] | None


class TaskSpec(NamedTuple):
  """Plain reward maximisation: nothing beyond the env's reward."""


Spec = MimaxSpec | DminSpec | TaskSpec
