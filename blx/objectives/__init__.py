"""blx.objectives — reward-free objectives as stateless functions, assembled into presets.

Building blocks (plain functions of arrays, written for one example) live in ``mimax``, ``priors``,
``posteriors``, ``dmin``, ``spectral`` and ``targets``; ``presets`` composes them into
``Objective``s: ``mimax_objective(prior, posterior)`` for MI-max, ``adversarial_objective`` (a
discriminator and a reward transform) and ``mle`` for D-min.
"""

from blx.objectives.base import Objective, Transition, for_agent, task
from blx.objectives.dmin import (airl_reward, discriminator_loss, fairl_reward, gail2_reward,
                                 gail_reward, gradient_penalty, mle_reward)
from blx.objectives.mimax import (categorical_log_q, categorical_offset, clip_logits,
                                  gaussian_log_q, gaussian_offset, mimax_reward)
from blx.objectives.posteriors import (Posterior, categorical_posterior, gaussian_posterior,
                                       identity_posterior)
from blx.objectives.presets import (adversarial_objective, airl, cdiayn, diayn, diayn_full, fairl,
                                    fixed_gcrl, gail, gail2, gcrl, list_objectives, make,
                                    mimax_objective, mle, option_defaults, options_of,
                                    resolve_indices)
from blx.objectives.priors import (Prior, categorical_prior, deterministic_prior,
                                   uniform_prior)
from blx.objectives.specs import DminSpec, MimaxSpec, Spec, TaskSpec
from blx.objectives.spectral import DiscriminatorMLP, SNDense, spectral_normalize
from blx.objectives.targets import Target, multimode_gaussian, target_from_samples

__all__ = [
    "Objective", "Transition", "task", "for_agent",
    "gcrl", "fixed_gcrl", "cdiayn", "diayn", "diayn_full", "gail", "gail2", "airl", "fairl", "mle",
    "make", "list_objectives", "options_of", "option_defaults", "resolve_indices",
    "mimax_objective", "adversarial_objective",
    "Posterior", "identity_posterior", "gaussian_posterior", "categorical_posterior",
    "MimaxSpec", "DminSpec", "TaskSpec", "Spec",
    "gaussian_log_q", "categorical_log_q", "clip_logits", "mimax_reward", "gaussian_offset",
    "categorical_offset",
    "Prior", "uniform_prior", "categorical_prior", "deterministic_prior",
    "discriminator_loss", "gail_reward", "gail2_reward", "airl_reward", "fairl_reward",
    "mle_reward", "gradient_penalty",
    "spectral_normalize", "SNDense", "DiscriminatorMLP",
    "Target", "multimode_gaussian", "target_from_samples",
]
