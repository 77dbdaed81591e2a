"""benchmarks/gait_search.py: gaits for any number of motors, the swing score is the RMS distance
from the target speed, the drift reads the last 2.5 s of constant actions, held poses are scored by
the rows' H(s) protocol, blx's halfcheetah comes to rest under constant actions (Brax v1's does
not), the procedural ant is searched at its own control step and ends upside down, the paper's
procedural ant is written as a Brax v1 config with blx's hips, and bad input is refused by name."""

import json
import sys

import numpy as np
import pytest

from tests.experiments import load_benchmark

gait_search = load_benchmark("gait_search")
ROW_STEP = {"global_options.timestep": 0.00625, "global_options.substeps": 8}


def test_gaits_take_the_motor_count_from_their_length():
  n = 6
  params = np.zeros((2, 3 * n + 1))
  params[0, 2 * n:3 * n] = np.linspace(-0.5, 0.5, n)        # bias only: the action is the bias
  params[1, :n], params[1, n:2 * n], params[1, 3 * n] = 1.0, np.pi / 2, 1.0   # sin(2 pi t + pi/2)
  actions = gait_search.gait_actions(params, t=0)
  assert actions.shape == (2, n)
  np.testing.assert_allclose(actions[0], np.linspace(-0.5, 0.5, n))
  np.testing.assert_allclose(actions[1], np.ones(n))
  np.testing.assert_allclose(gait_search.gait_actions(params, t=10)[1], -np.ones(n), atol=1e-9)


def test_swing_is_the_rms_distance_from_the_target():
  t = np.arange(100) * gait_search.DT
  steady = np.full((1, 100, 1), 1.5)
  swinging = (1.5 + 0.4 * np.sin(2 * np.pi * t))[None, :, None]   # whole periods
  slow = np.full((1, 100, 1), 1.2)
  velocities = np.concatenate([steady, swinging, slow, steady])
  alive = np.array([True, True, True, False])
  score = gait_search.swing_score(velocities, alive, target=1.5)
  np.testing.assert_allclose(score, [0.0, -0.4 / np.sqrt(2), -0.3, -100.0], atol=1e-9)
  profile = gait_search.speed_profile(velocities[:3])
  np.testing.assert_allclose(profile["mean_speed"], [1.5, 1.5, 1.2], atol=1e-9)
  np.testing.assert_allclose(profile["std_speed"], [0.0, 0.4 / np.sqrt(2), 0.0], atol=1e-9)


def test_the_search_climbs_a_known_score():
  # score: minus the distance of the first bias from 0.3; the search must find it
  def score(params):
    return -np.abs(params[:, 2 * 4] - 0.3)
  found = gait_search.cross_entropy(score, num_motors=4, seed=0, iters=15)
  assert found["elite_params"].shape == (gait_search.ELITE, 13)
  assert found["best"] > -0.01 and found["elite_means"][-1] > found["elite_means"][0]


def test_drift_reads_the_last_two_and_a_half_seconds():
  last = int(round(2.5 / gait_search.DT))

  def rollout(params):
    v = np.zeros((len(params), gait_search.STEPS - gait_search.WARM, 1))
    v[:, :-last] = 5.0                       # fast early on: not the drift
    v[:, -last:, 0] = -params[:, 2 * 6:2 * 6 + 1]   # the last 2.5 s at minus the first bias
    return v, np.zeros(len(params)), np.ones(len(params), bool)

  found = gait_search.constant_action_drift(rollout, num_motors=6, poses=8, seed=3)
  bias = np.random.default_rng(3).uniform(-1, 1, (8, 6))[:, 0]
  np.testing.assert_allclose(found["drift"], np.abs(bias))
  assert found["share_above_0_1"] == np.mean(np.abs(bias) > 0.1)


def test_held_poses_are_scored_on_the_last_500_steps_with_the_given_noise():
  seen = {}

  def rollout(params, steps, noise):
    seen.update(steps=steps, noise=noise)
    v = np.full((len(params), steps - gait_search.WARM, 1), 4.0)   # early steps: not scored
    v[:, -500:, 0] = params[:, 2 * 6:2 * 6 + 1]                    # then at the first bias
    return v, np.zeros(len(params)), np.ones(len(params), bool)

  found = gait_search.held_pose_entropy(rollout, num_motors=6, poses=8, sigma=0.3, seed=1)
  assert seen["steps"] == 1000 and seen["noise"].shape == (1000, 8, 6)
  assert abs(seen["noise"].std() - 0.3) < 0.01
  # eight poses, each at its own speed for all 500 scored steps: eight equal bins, ln 8
  np.testing.assert_allclose(found["entropy"], np.log(8), rtol=1e-5)
  bias = np.random.default_rng(1).uniform(-1, 1, (8, 6))[:, 0]
  np.testing.assert_allclose(found["pose_speed"], bias)


def test_blx_halfcheetah_comes_to_rest_under_constant_actions():
  # Brax v1's halfcheetah at the paper's step keeps moving: median 0.19 m/s, 74% of 96 poses
  # above 0.1 m/s (RESULTS session 45). Sound physics brings a held pose to rest.
  rollout, motors = gait_search.blx_rollout("halfcheetah", ROW_STEP, cut=True)
  assert motors == 6
  found = gait_search.constant_action_drift(rollout, motors, poses=12)
  assert all(found["alive"])
  assert found["median"] < 0.05 and found["share_above_0_1"] <= 0.25
  # the action noise reaches the motors: none (or zeros) leaves a rollout as it was, some moves it
  params = np.zeros((2, 3 * motors + 1))
  params[:, 2 * motors:3 * motors] = 0.4
  quiet, _, _ = rollout(params, 40)
  zeros, _, _ = rollout(params, 40, np.zeros((40, 2, motors)))
  noisy, _, _ = rollout(params, 40, 0.5 * np.random.default_rng(0).standard_normal((40, 2, motors)))
  np.testing.assert_array_equal(quiet, zeros)
  assert quiet.shape == (2, 40 - gait_search.WARM, 1) and np.abs(noisy - quiet).max() > 0.05


def test_the_procedural_ant_is_searched_at_its_own_control_step_and_ends_upside_down():
  rollout, motors = gait_search.blx_rollout("pro_ant_run", None, cut=True,
                                            env_params={"num_legs": 3})
  assert motors == 6   # a hip and a knee per leg
  standing = np.zeros((1, 3 * motors + 1))   # amplitude 0, bias 0: every action 0
  velocities, speed, alive = rollout(standing)
  # 6 s at 0.02 s a control step, the first second a warm-up: 250 steps recorded (at the ant's
  # 0.05 s the same episode is 100)
  assert velocities.shape == (1, 250, 2)
  assert alive[0] and speed[0] < 0.05
  assert gait_search.upside_down(np.array([0.0, 1.0, 0.0, 0.0]))   # turned about x by pi
  assert not gait_search.upside_down(np.array([np.cos(0.6), np.sin(0.6), 0.0, 0.0]))  # 1.2 rad


def test_the_papers_procedural_ant_is_written_as_a_brax_config_with_blx_s_hips():
  import re

  from blx import envs
  text = gait_search.brax_pro_ant_config(3)
  assert text.count("bodies {") == 1 + 2 * 3 + 1   # torso, a thigh and a shin a leg, the ground
  assert text.count("joints {") == 6 and text.count("actuators {") == 6
  assert text.count("strength: 300.0") == 6
  # every ant body collides with the ground, and nothing else collides
  assert re.findall(r'collide_include \{ first: "(\w+)" second: "Ground" \}', text) == [
      "torso", "thigh_0", "shin_0", "thigh_1", "shin_1", "thigh_2", "shin_2"]
  assert "dt: 0.02" in text and "substeps: 16" in text and "friction: 1.0" in text
  hips = [(float(x), float(y)) for x, y in re.findall(
      r"parent_offset \{ x: ([-\d.e]+) y: ([-\d.e]+) \}", text)]
  turns = [float(z) for z in re.findall(r"reference_rotation \{ z: ([-\d.e]+) \}", text)]
  np.testing.assert_allclose(turns, [0.0, 120.0, 240.0])
  # the hips where blx's pro_ant (MJCF) puts its thighs: the same body, built twice
  model = envs.unwrap(envs.create("pro_ant_run", num_legs=3)).mj_model
  thighs = [model.body(f"agent1/thigh_{i}").pos[:2] for i in (1, 2, 3)]
  np.testing.assert_allclose(hips, thighs, atol=1e-6)  # the MJCF keeps 6 decimals
  assert gait_search.brax_pro_ant_config(4, strength=350.0).count("strength: 350.0") == 8
  for bad in (1, 17, 3.0, True):
    with pytest.raises(ValueError, match=r"takes 2\.\.16 legs"):
      gait_search.brax_pro_ant_config(bad)


@pytest.mark.parametrize("argv, message", [
    (["--sim", "blx", "--score", "swing"], "--target is required by --score swing"),
    (["--sim", "blx", "--target", "1.5"], "--target is required by --score swing"),
    (["--sim", "blx", "--body", "halfcheetah", "--score", "energy"], "--body ant only"),
    (["--sim", "blx", "--drift", "0"], "--drift takes a number of poses"),
    (["--sim", "blx", "--drift", "8", "--score", "swing", "--target", "1"], "--drift takes"),
    (["--sim", "blx", "--brax-set", "substeps=64"], "--sim brax only"),
    (["--sim", "blx", "--brax-config", "x.txt"], "--brax-config is for --sim brax"),
    (["--sim", "brax"], "--sim brax --body ant needs --brax-config"),
    (["--sim", "brax", "--body", "pro_ant_run", "--brax-config", "x.txt"], "give no --brax-config"),
    (["--sim", "brax", "--body", "pro_ant_run", "--env-param", "step=blx"],
     "takes --env-param num_legs=N alone, got ['step']"),
    (["--sim", "brax", "--body", "pro_ant_run", "--env-param", "num_legs=1"],
     "--env-param num_legs=1: the procedural ant takes 2..16 legs"),
    (["--sim", "brax", "--brax-config", "x.txt", "--no-cut"], "--sim blx only"),
    (["--sim", "brax", "--brax-config", "x.txt", "--brax-set", "k=1"], "the field must be one of"),
    (["--sim", "brax", "--brax-config", "x.txt", "--brax-set", "dt=a"], "must be a number"),
    (["--sim", "blx", "--seeds", "0"], "--seeds and --iters must be at least 1"),
    ([], "--sim is required (blx or brax) unless --plot or --plot-legs"),
    (["--plot-legs", "a.json", "b.json"], "--plot-legs takes the PNG to write"),
    (["--sim", "blx", "--held", "8", "--noise", "0.1"], "--body halfcheetah"),
    (["--sim", "blx", "--body", "halfcheetah", "--held", "8"], "--held needs it"),
    (["--sim", "blx", "--body", "halfcheetah", "--noise", "0.1"], "--noise (a std >= 0) goes"),
    (["--sim", "blx", "--body", "halfcheetah", "--held", "8", "--noise", "-1"], "a std >= 0"),
    (["--sim", "brax", "--brax-config", "x.txt", "--env-param", "num_legs=3"],
     "or the legs of --sim brax --body pro_ant_run"),
    (["--sim", "blx", "--body", "pro_ant_run", "--drift", "8"], "--body ant or halfcheetah"),
    (["--sim", "blx", "--body", "pro_ant_run", "--env-param", "num_legs"], "takes KEY=VALUE"),
    (["--sim", "blx", "--body", "pro_ant_run", "--env-param", "legs=3"],
     "--body pro_ant_run with --env-param ['legs=3']"),
    (["--plot", "a.json", "b.json"], "--plot takes the PNG to write"),
    (["--plot", "a.png", "missing.json"], "--plot: [Errno 2]"),
])
def test_bad_input_is_named(monkeypatch, capsys, argv, message):
  monkeypatch.setattr(sys, "argv", ["gait_search.py", *argv])
  with pytest.raises(SystemExit) as exit_:
    gait_search.main()
  assert exit_.value.code == 2 and message in capsys.readouterr().err


def test_runs_are_described_by_their_physics():
  brax = dict(sim="brax", body="halfcheetah", brax_set=[])
  assert gait_search.describe(brax) == "Brax v1 halfcheetah, 16 x 3.125 ms (the paper's)"
  assert gait_search.describe({**brax, "brax_set": ["substeps=64"]}) == (
      "Brax v1 halfcheetah, 64 x 0.7812 ms")
  assert gait_search.describe({**brax, "brax_set": ["baumgarte_erp=0.1"]}) == (
      "Brax v1 halfcheetah, 16 x 3.125 ms, baumgarte_erp 0.1")
  assert gait_search.describe(dict(sim="brax", body="ant")) == (
      "Brax v1 ant, 10 x 5 ms (the paper's)")
  assert gait_search.describe(dict(sim="brax", body="pro_ant_run", env_param=["num_legs=3"])) == (
      "Brax v1 pro_ant_run num_legs=3, 16 x 1.25 ms (the paper's)")
  blx = dict(sim="blx", body="halfcheetah", edits='{"global_options.timestep": 0.00625, '
             '"global_options.substeps": 8}')
  assert gait_search.describe(blx) == "blx halfcheetah, 8 x 6.25 ms"
  assert gait_search.describe(dict(sim="blx", body="pro_ant_run", env_param=["num_legs=3"])) == (
      "blx pro_ant_run num_legs=3, its default step")


def test_the_legs_plot_groups_searches_and_trained_runs_by_physics_and_leg_count(tmp_path):
  def search(sim, legs, elites):
    args = dict(sim=sim, body="pro_ant_run", score="speed", env_param=[f"num_legs={legs}"])
    return dict(args=args, seeds={str(i): dict(elite_last=e, best=e + 0.3)
                                  for i, e in enumerate(elites)})
  files = {"blx3.json": search("blx", 3, [1.5, 1.4]), "brax3.json": search("brax", 3, [1.4]),
           "brax3b.json": search("brax", 3, [1.6]), "brax4.json": search("brax", 4, [2.2]),
           "trained3.json": dict(env="pro_ant_run", env_params={"num_legs": 3},
                                 per_seed={"0": dict(velocity=[2.3, 0.0]),
                                           "1": dict(velocity=[2.9, 0.0])}),
           # the row's PPO at another budget joins the row's; a larger entropy cost stands apart
           "trained3_budget.json": dict(env="pro_ant_run", env_params={"num_legs": 3},
                                        ppo={"num_timesteps": 300_000_000},
                                        per_seed={"0": dict(velocity=[0.0, 2.0])}),
           "trained3_entropy.json": dict(env="pro_ant_run", env_params={"num_legs": 3},
                                         ppo={"num_timesteps": 300_000_000, "entropy_cost": 0.1},
                                         env_steps=75_366_400.0,
                                         per_seed={"0": dict(velocity=[3.0, 4.0])})}
  paths = []
  for name, value in files.items():
    paths.append(str(tmp_path / name))
    (tmp_path / name).write_text(json.dumps(value))
  png = tmp_path / "legs.png"
  groups, steps = gait_search.plot_legs(paths, str(png))
  assert groups == {("blx", 3): [1.5, 1.4], ("Brax v1", 3): [1.4, 1.6], ("Brax v1", 4): [2.2],
                    ("trained", 3): [2.3, 2.9, 2.0], ("trained, entropy_cost=0.1", 3): [5.0]}
  # each trained bar names how far its runs had trained; a JSON without env_steps, "?"
  assert steps == {("trained", 3): "?", ("trained, entropy_cost=0.1", 3): "75 M"}
  files["trained3.json"]["env_steps"] = 105_512_960.0
  (tmp_path / "trained3.json").write_text(json.dumps(files["trained3.json"]))
  assert gait_search.plot_legs(paths, str(png))[1][("trained", 3)] == "106 M/?"
  assert png.stat().st_size > 10_000
  swing = search("blx", 3, [1.0])
  swing["args"]["score"] = "swing"
  (tmp_path / "swing.json").write_text(json.dumps(swing))
  with pytest.raises(ValueError, match="neither a speed search of --body pro_ant_run"):
    gait_search.plot_legs([str(tmp_path / "swing.json")], str(png))


def test_the_study_plot_takes_only_this_scripts_runs(tmp_path):
  args = dict(sim="brax", body="halfcheetah", brax_set=[], score="speed")
  drift = tmp_path / "drift.json"
  drift.write_text(json.dumps(dict(args=args, drift=[0.2, 0.01], share_above_0_1=0.5)))
  swing = tmp_path / "swing.json"
  swing.write_text(json.dumps(dict(args={**args, "score": "swing", "target": 1.5},
                                   seeds={"0": dict(elite_last=-0.1)})))
  held = tmp_path / "held.json"
  held.write_text(json.dumps(dict(args=args, entropy=5.0, sigma=0.1)))
  png = tmp_path / "study.png"
  gait_search.plot_study([str(drift), str(swing)], str(png))
  two_panels = png.stat().st_size
  assert two_panels > 10_000
  gait_search.plot_study([str(drift), str(swing), str(held)], str(png))
  assert png.stat().st_size > two_panels   # the held poses' panel is drawn
  other = tmp_path / "other.json"
  other.write_text(json.dumps(dict(args={**args, "score": "energy"}, seeds={})))
  with pytest.raises(ValueError, match="is a swing search or a drift run"):
    gait_search.plot_study([str(other)], str(png))
