"""Plot labels a reader needs to read the training curves."""

from blx import objectives
from blx.experiments import plots


def test_mode_share_panels_name_the_mode_they_count():
  gail = objectives.gail(obs_indices=(2, 3), obs_scale=8.0)  # modes (4, 0) and (-4, 0)
  titles = plots.curve_titles(["eval/mode_share/0", "eval/mode_share/1",
                               "eval/episode_mode_share/1", "eval/energy_distance"], gail)
  assert titles["eval/mode_share/0"] == "eval/mode_share/0: nearest (4, 0)"
  assert titles["eval/mode_share/1"] == "eval/mode_share/1: nearest (-4, 0)"
  assert titles["eval/episode_mode_share/1"] == "eval/episode_mode_share/1: nearest (-4, 0)"
  assert titles["eval/energy_distance"] == "eval/energy_distance"
  # an objective without a target keeps the keys
  assert plots.curve_titles(["eval/mode_share/0"], objectives.task()) == {
      "eval/mode_share/0": "eval/mode_share/0"}
