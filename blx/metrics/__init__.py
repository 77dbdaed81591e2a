"""blx.metrics — stationary metrics of reward-free behaviour: pure functions of arrays
(``particle``) and the evaluation helpers that roll trained policies out to feed them
(``evaluate``)."""

from blx.metrics.evaluate import (LGR_GOAL_DRAWS, Evaluator, alive_mask, alive_share,
                                  braxlines_end, braxlines_mutual_information, braxlines_window,
                                  dmin_evaluator, draws_latents, episode_batch, eval_indices,
                                  evaluate_dmin, evaluate_mimax,
                                  infer_goal_latents, latents_for_evaluation, lgr_goals,
                                  mimax_evaluator, mode_balance, mode_shares, rollout)
from blx.metrics.families import (PLOTS, Family, evaluator_for, family_of, register_family,
                                  scored_steps)
from blx.metrics.particle import (energy_distance, entropy, entropy_2d, latent_goal_reaching,
                                  mutual_information, mutual_information_2d, state_coverage)

__all__ = ["energy_distance", "entropy", "entropy_2d", "latent_goal_reaching",
           "mutual_information", "mutual_information_2d", "state_coverage",
           "rollout", "episode_batch", "Evaluator", "draws_latents", "latents_for_evaluation",
           "eval_indices", "lgr_goals", "LGR_GOAL_DRAWS", "infer_goal_latents", "mimax_evaluator",
           "dmin_evaluator", "mode_shares", "mode_balance", "alive_share", "alive_mask",
           "braxlines_end", "braxlines_window", "braxlines_mutual_information", "evaluate_mimax",
           "evaluate_dmin", "Family", "register_family", "family_of", "evaluator_for",
           "scored_steps", "PLOTS"]
