"""blx.metrics — stationary metrics of reward-free behaviour, as pure functions of arrays."""

from blx.metrics.particle import (energy_distance, entropy, entropy_2d, latent_goal_reaching,
                                  mutual_information, mutual_information_2d, state_coverage)

__all__ = ["energy_distance", "entropy", "entropy_2d", "latent_goal_reaching",
           "mutual_information", "mutual_information_2d", "state_coverage"]
