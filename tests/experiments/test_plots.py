"""Plot labels a reader needs to read the training curves."""

import numpy as np
import pytest

from blx import objectives, training
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


def test_curve_panels_say_what_they_measure_and_what_the_band_is(tmp_path):
  assert plots.curve_ylabel("eval/mi") == "MI(s; z) (nats)"
  assert plots.curve_ylabel("eval/mode_share/1") == "share of samples"
  assert plots.curve_ylabel("eval/episode_mode_share/0") == "share of episodes"
  assert plots.curve_ylabel("train/some_new_thing") == "some new thing"  # unknown keys stay legible
  assert plots.band_caption(10).startswith("line: mean over 10 seeds, band: lowest to highest seed")
  assert plots.band_caption(1).startswith("one seed")
  # the paper's metrics come from the evaluator's sampled episodes, the returns from the trainer's,
  # which act as the run's eval_actions says: the caption tells them apart where both are drawn
  both = plots.band_caption(10, ["eval/episode_reward", "eval/energy_distance", "loss/disc"],
                            "mean")
  assert "trainer's evaluation episodes after each chunk (the mean action)" in both
  assert "evaluator after each chunk,\nactions sampled" in both
  returns_only = plots.band_caption(10, ["eval/episode_reward", "eval/episode_length"], "sampled")
  assert "evaluation episodes after each chunk (actions sampled)" in returns_only
  assert "mean action" not in plots.band_caption(10, ["eval/episode_reward"], "sampled")
  assert "(" not in plots.band_caption(10, ["eval/episode_reward"]).split(";")[0]  # not said
  assert plots.curve_ylabel("eval/episode_length") == "env steps per episode"
  history = [{"env_steps": 1e6 * (i + 1), "eval/mi": [0.1 * i, 0.2 * i], "loss/policy": [1.0, 2.0],
              "eval/episode_length": [1000.0, 240.0], "eval/episode_score": [-1e3, -8e2],
              "train/reward": [0.0, 0.0]} for i in range(3)]
  path = tmp_path / "curves.png"
  # the length beside the score it qualifies; keys outside the panels' patterns are left out
  assert plots.training_curves(history, str(path), title="diayn on point") == [
      "eval/episode_score", "eval/episode_length", "eval/mi", "loss/policy"]
  assert path.stat().st_size > 0


def test_ppos_gradient_panels_are_drawn_and_a_statistic_first_logged_at_a_resume_too(tmp_path,
                                                                                     monkeypatch):
  # grad_norm is logged by every run; grad_clipped only with max_grad_norm set, so a run resumed
  # with a newer blx logs it from its resume on: its panel starts there, a gap before it.
  history = [{"env_steps": 1e6 * (i + 1), "eval/mi": [0.1 * i, 0.2 * i], "grad_norm": [3.0, 4.0],
              **({"grad_clipped": [0.1, 0.3]} if i >= 2 else {})} for i in range(4)]
  panels = []  # each drawn panel's title and x range, as saved
  monkeypatch.setattr("matplotlib.figure.Figure.savefig", lambda fig, *a, **k: panels.extend(
      (ax.get_title(), ax.get_xlim()) for ax in fig.axes if ax.axison))
  keys = plots.training_curves(history, str(tmp_path / "curves.png"))
  assert keys == ["eval/mi", "grad_norm", "grad_clipped"]
  (mi, mi_span), (_, norm_span), (clipped, clipped_span) = panels
  assert mi == "eval/mi" and clipped == "grad_clipped\n(logged from 3M on)"
  assert clipped_span == mi_span == norm_span  # every panel spans the whole run
  np.testing.assert_array_equal(plots._curve(history, "grad_clipped"),
                                [[np.nan, np.nan], [np.nan, np.nan], [0.1, 0.3], [0.1, 0.3]])
  assert plots.curve_ylabel("grad_clipped") == "share of SGD steps clipped"
  assert plots.curve_ylabel("grad_norm") == "gradient norm (before any clip)"
  assert "grad_*: means over the chunk's training iterations" in plots.band_caption(2, keys)


def test_a_run_resumed_across_the_lgr_goals_change_has_it_marked_in_its_lgr_panel(tmp_path,
                                                                                 monkeypatch):
  import matplotlib.axes

  from blx.experiments import runs

  def segment(start, end, goals):
    return runs.Segment("2026-11-27T00:00:00Z", start, end, "H200", "gpu", 1, {}, lgr_goals=goals)

  # begun before session 41 (no lgr_goals), resumed after; begun after; begun before provenance
  assert runs.lgr_goals_switch([segment(0, 2e6, None), segment(2e6, 3e6, "braxlines")]) == 2e6
  assert runs.lgr_goals_switch([segment(0, 3e6, "braxlines")]) is None
  assert runs.lgr_goals_switch([segment(0, 3e6, None)]) is None
  assert runs.lgr_goals_switch([segment(1e6, 3e6, "braxlines")]) == 1e6
  assert runs.lgr_goals_switch([]) is None
  lines = []
  real = matplotlib.axes.Axes.axvline
  monkeypatch.setattr(matplotlib.axes.Axes, "axvline",
                      lambda ax, x, **kw: lines.append((ax, x)) or real(ax, x, **kw))
  history = [{"env_steps": 1e6 * (i + 1), "eval/mi": [0.1 * i], "eval/lgr": [2.0 - i]}
             for i in range(3)]
  plots.training_curves(history, str(tmp_path / "curves.png"), lgr_goals_from=2e6)
  assert [(ax.get_title(), x) for ax, x in lines] == [  # that panel only, which says so
      ("eval/lgr\n(left of the dashed line: blx's old goals)", 2e6)]
  lines.clear()
  plots.training_curves(history, str(tmp_path / "curves.png"))
  assert lines == []


@pytest.mark.parametrize("key, lengths, bottom", [
    ("eval/episode_length", [1000.0, 1000.0, 999.8], 0.0),  # episodes (nearly) all to the end
    ("eval/episode_length", [240.0, 300.0, 360.0], 0.0),
    # a score keeps its own range; a narrow one far from 0 would otherwise get an offset
    ("eval/episode_score", [-8000.0, -7999.9, -7999.8], None),
])
def test_a_panels_ticks_are_its_values_and_a_length_is_drawn_from_zero(key, lengths, bottom):
  from matplotlib.figure import Figure
  ax = Figure().add_subplot()
  ax.plot([1e6, 2e6, 3e6], lengths)
  plots.value_axis(ax, key)
  ax.figure.canvas.draw()
  assert ax.yaxis.get_offset_text().get_text() == ""  # no "+1e3" to add to every tick in the head
  lo, hi = ax.get_ylim()
  assert hi >= max(lengths)
  if bottom is None:
    assert lo > -8001.0  # not stretched to 0
  else:
    assert lo == bottom
  shown = [(loc, float(t.get_text().replace("\u2212", "-")))
           for loc, t in zip(ax.get_yticks(), ax.get_yticklabels()) if lo <= loc <= hi]
  assert len(shown) >= 3 and all(v == pytest.approx(loc) for loc, v in shown)  # labels are values


def test_video_frames_carry_their_label_and_keep_the_scene():
  import numpy as np

  from blx.experiments import render
  frames = np.full((3, 240, 160, 3), 128, np.uint8)
  zero, three = render.label_frames(frames, "diayn: skill 0"), render.label_frames(frames, "skill 3")
  band = 240 // 12  # the band is a twelfth of the height
  assert (zero[:, band:] == frames[:, band:]).all()  # the scene below the band is untouched
  assert (zero[:, :band] != frames[:, :band]).any()  # the band is drawn
  assert (zero[:, :band] != three[:, :band]).any()  # and says which episode this is
  assert (zero[0] == zero[2]).all()  # the same label on every frame of an episode


def test_a_two_line_label_takes_two_lines_of_band():
  import numpy as np

  from blx.experiments import render
  frames = np.full((2, 240, 320, 3), 128, np.uint8)
  two = render.label_frames(frames, "task on chase\nagent0 blue, agent1 orange")
  line = 240 // 12
  assert (two[:, 2 * line:] == frames[:, 2 * line:]).all()
  assert (two[:, line:2 * line] != frames[:, line:2 * line]).any()  # the second line is drawn
  one = render.label_frames(frames, "task on chase")
  assert (one[:, line:] == frames[:, line:]).all()


def test_each_agent_of_a_scene_gets_its_own_colour_and_nothing_else_changes():
  import numpy as np

  from blx import envs
  from blx.experiments import render
  env = envs.create("chase", main_agent="point", other_agent="point")
  model = envs.unwrap(env).mj_model
  before = np.array(model.geom_rgba, copy=True)
  coloured, legend = render.colour_agents(model, ("agent0", "agent1"))
  assert legend == "agent0 blue, agent1 orange"
  np.testing.assert_array_equal(model.geom_rgba, before)  # the env's own model is untouched
  owner = [model.body(int(b)).name.split("/")[0] for b in model.geom_bodyid]
  for g, agent in enumerate(owner):
    if agent in ("agent0", "agent1"):
      want = dict(render.AGENT_COLOURS)["blue" if agent == "agent0" else "orange"]
      np.testing.assert_allclose(coloured.geom_rgba[g], want)
    else:  # the floor and anything else in the scene
      np.testing.assert_array_equal(coloured.geom_rgba[g], before[g])
  assert {"agent0", "agent1"} <= set(owner) and len(set(owner)) > 2


def test_skills_get_clearly_distinct_colours_and_paths_are_drawn(tmp_path):
  import numpy as np
  for num in (4, 8, 16, 30):
    colours = np.asarray(plots.skill_colours(num))[:, :3]
    gaps = np.abs(colours[:, None] - colours[None]).sum(-1) + np.eye(num) * 9
    assert gaps.min() > 0.05, num  # no two skills share a colour
  xy = np.cumsum(np.ones((3, 2, 10, 2)), axis=2) * np.arange(1, 4)[:, None, None, None]
  path = tmp_path / "paths.png"
  plots.paths(xy, str(path), body="agent1/root", title="diayn on point")
  assert path.stat().st_size > 0


def test_draw_paths_draws_each_episode_in_its_skills_colour_with_its_ends_and_starts():
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  import numpy as np
  xy = np.random.default_rng(0).normal(size=(3, 2, 5, 2))  # 3 skills, 2 episodes, 5 steps
  colours = plots.skill_colours(3)
  fig, ax = plt.subplots()
  plots.draw_paths(ax, xy, colours, legend=True)
  lines = ax.get_lines()
  assert len(lines) == 6
  for i, line in enumerate(lines):  # skill k's episodes come k-th, in its colour
    k, m = divmod(i, 2)
    np.testing.assert_allclose(line.get_xydata(), xy[k, m])
    assert matplotlib.colors.same_color(line.get_color(), colours[k])
  *ends, starts = ax.collections
  for k, dots in enumerate(ends):
    np.testing.assert_allclose(dots.get_offsets(), xy[k, :, -1])
  np.testing.assert_allclose(starts.get_offsets(), xy[:, :, 0].reshape(-1, 2))
  assert [t.get_text() for t in ax.legend().get_texts()] == ["skill 0", "skill 1", "skill 2",
                                                             "start"]
  plt.close(fig)


def test_a_run_trained_off_its_envs_ppo_row_says_so_in_its_plots_titles(tmp_path, monkeypatch):
  from types import SimpleNamespace

  from blx.experiments import runs
  titles, actions = [], []
  monkeypatch.setattr(plots, "training_curves", lambda history, path, **kw: (
      titles.append(kw["title"]), actions.append(kw["eval_actions"])))
  row = training.ppo_defaults("halfcheetah")
  # The third run's config.json sets nothing, but it trained with the mean action, blx's default
  # before session 61 (run.config: as load_run rebuilds it): its title names the setting.
  for ppo, config in (({"max_grad_norm": 5, "num_evals": 40}, {}), ({"num_evals": 40}, {}),
                      ({}, {"eval_actions": "mean"})):
    run = SimpleNamespace(directory=str(tmp_path), params=None,
                          objective=objectives.diayn(num_skills=2, obs_indices=(0,)),
                          spec=runs.RunSpec(env="halfcheetah", objective="diayn",
                                            objective_options={}, ppo=ppo),
                          config=row.replace(**ppo, **config))
    plots.write_all(run, [{"env_steps": 1.0, "eval/mi": [0.1]}])
  assert titles == ["diayn on halfcheetah; PPO max_grad_norm 5 (default None): training curves",
                    "diayn on halfcheetah: training curves",
                    "diayn on halfcheetah; PPO eval_actions mean (default sampled): training "
                    "curves"]
  assert actions == ["sampled", "sampled", "mean"]  # the caption says how each run's episodes act


def test_fit_title_wraps_each_line_to_the_figures_width_and_keeps_every_word():
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  fig = plt.figure(figsize=(5, 3))  # 5 in at 10 pt: 60 characters a line
  first = " ".join(f"word{i}" for i in range(40))
  fitted = plots.fit_title(first + "\nshort second line", fig)
  lines = fitted.split("\n")
  assert len(lines) > 3 and all(len(line) <= 60 for line in lines)
  assert lines[-1] == "short second line"  # a line break of the text stays one
  assert " ".join(lines[:-1]) == first
  assert plots.fit_title("fits", fig) == "fits"
  plt.close(fig)


def test_a_run_directory_plots_long_title_is_wrapped_to_its_figure(tmp_path, monkeypatch):
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.figure
  import numpy as np
  titles = []
  save = matplotlib.figure.Figure.savefig

  def spy(fig, *args, **kwargs):
    titles.append(fig._suptitle.get_text())
    return save(fig, *args, **kwargs)

  monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
  title = ("gcrl on halfcheetah; PPO learning_rate 0.00015 (default 0.0003), max_grad_norm 5 "
           "(default None) (seed 0)")
  xy = np.cumsum(np.ones((3, 2, 10, 2)), axis=2)
  plots.paths(xy, str(tmp_path / "paths.png"), body="torso", title=title)
  # the 4.8 in figure holds 57 characters a line at 10 pt: the title takes two lines, every word
  assert titles[0].count("\n") >= 1 and max(map(len, titles[0].split("\n"))) <= 57
  assert titles[0].replace("\n", " ") == f"{title}: paths"
