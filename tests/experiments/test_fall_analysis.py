"""benchmarks/fall_analysis.py: the split of an MI-max row's scored states into those before and
after each episode's end, on a stand-in env whose skills are known points until a fall."""

import json
from types import SimpleNamespace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, metrics, objectives, training
from blx.running_stats import RunningStats
from tests.experiments import load_benchmark

fall_analysis = load_benchmark("fall_analysis")

K = 4


class _FallsAtSix:
  """Observation: the action while standing, 0 from the step after the fall; the episode ends
  (a fall) at step 6."""

  observation_size, action_size = 1, 1

  def reset(self, key):
    from blx.envs.env import State
    return State(data=jnp.zeros(()), obs=jnp.zeros(1), reward=jnp.zeros(()), done=jnp.zeros(()))

  def step(self, state, action):
    t = state.data + 1.0
    return state.replace(data=t, obs=jnp.where(t <= 6.0, action, 0.0),
                         done=(t >= 6.0).astype(jnp.float32))


def _skill_policy(params, obs, z, key=None, deterministic=False):
  return (jnp.argmax(z, -1).astype(jnp.float32) + 1.0)[:, None]  # skill k stands at k + 1


def _tanh_gaussian(params, obs, z=None, key=None, deterministic=False):
  """One action per observation entry: tanh(0.3) as the mean, tanh(0.3 + 2 N(0, 1)) sampled."""
  u = jnp.full(obs.shape, 0.3)
  return jnp.tanh(u if deterministic else u + 2.0 * jax.random.normal(key, obs.shape))


def test_the_states_after_the_falls_are_split_from_those_before():
  # 8-step episodes, the last 4 scored (steps 5-8): steps 5 and 6 (the fall) count as standing, 7
  # and 8 come after. Before the falls the skills are at 1..4: MI = log K. With the fallen states
  # (all at 0, half of each skill's) the protocol's MI is H(s) - H(s|z) = (log 2 + log 2K) / 2 -
  # log 2 = log(K) / 2.
  run = SimpleNamespace(env=envs.episode(_FallsAtSix(), 8), policy=_skill_policy,
                        objective=objectives.diayn(num_skills=K, obs_indices=(0,), obs_scale=5.0))
  out = jax.jit(lambda k: fall_analysis.analyse(run, {}, k, deterministic=True, draws=3))(
      jax.random.PRNGKey(0))
  np.testing.assert_allclose(out["alive_share"], 0.5)
  np.testing.assert_allclose(out["mi_alive"], np.log(K), rtol=1e-5)
  np.testing.assert_allclose(out["mi"], np.log(K) / 2, rtol=1e-5)
  np.testing.assert_allclose(out["end_step"], 6)
  np.testing.assert_allclose(out["last_end_step"], 6)
  np.testing.assert_allclose(out["speed_after"], 0.0)
  np.testing.assert_allclose(out["speed_alive"], np.mean(np.arange(1, K + 1)))
  # Every episode is down at once from step 6, so Braxlines' rollout keeps s_0 .. s_5 and scores
  # its last 4 (s_2 .. s_5), all standing: the skills' MI is whole.
  np.testing.assert_allclose(out["braxlines_end"], 6)
  np.testing.assert_allclose(out["mi_braxlines"], np.log(K), rtol=1e-5)
  # The control keeps as many states per skill, at random places: it mixes in fallen states, so it
  # reads near the protocol (about half of each subset fallen) and far below the states before
  # the falls.
  assert abs(out["mi_subset"] - out["mi"]) < 0.2
  assert out["mi_subset"] < out["mi_alive"] - 0.4


def test_the_command_refuses_a_seed_the_run_does_not_have(tmp_path, monkeypatch):
  run = SimpleNamespace(spec=SimpleNamespace(seeds=(0, 1), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=K, obs_indices=(0,)))
  monkeypatch.setattr(fall_analysis.runs, "load_run", lambda directory: run)
  for bad in ("0,2", "one"):
    with pytest.raises(SystemExit):
      fall_analysis.main([str(tmp_path), "--seeds", bad])


def test_scaled_noise_moves_the_pre_tanh_action_between_mean_and_sample():
  # A policy with mean 0.3 and std 2 before the tanh: scale 1 is its sample, 0 its mean, and 0.5
  # half the noise, all with the same key.
  obs, key = jnp.zeros((5, 2)), jax.random.PRNGKey(3)
  noise = 2.0 * jax.random.normal(key, obs.shape)
  for scale in (0.0, 0.5, 1.0):
    np.testing.assert_allclose(fall_analysis.scaled_noise(_tanh_gaussian, scale)({}, obs, key=key),
                               np.tanh(0.3 + scale * noise), atol=1e-5)


def test_noise_on_some_actions_keeps_the_mean_on_the_others():
  # Mean 0.3, std 2 on three actions; the noise on the first and third alone, at scale 1 and 0.5.
  obs, key = jnp.zeros((4, 3)), jax.random.PRNGKey(5)
  noise = 2.0 * jax.random.normal(key, obs.shape)
  where = np.array([True, False, True])
  for scale in (1.0, 0.5):
    out = fall_analysis.scaled_noise(_tanh_gaussian, scale, where)({}, obs, key=key)
    np.testing.assert_allclose(out[:, 1], np.tanh(0.3), atol=1e-6)
    np.testing.assert_allclose(out[:, [0, 2]], np.tanh(0.3 + scale * noise[:, [0, 2]]), atol=1e-5)


def test_noise_on_names_the_joints_by_pattern_and_refuses_a_pattern_that_names_none():
  names = ("agent1/abdomen_z", "agent1/right_hip_x", "agent1/right_knee", "agent1/left_hip_x",
           "agent1/left_elbow")
  np.testing.assert_array_equal(fall_analysis.noisy_actions(names, ["*hip*", "*knee"]),
                                [False, True, True, True, False])
  np.testing.assert_array_equal(fall_analysis.noisy_actions(names, ["agent1/abdomen*"]),
                                [True, False, False, False, False])
  with pytest.raises(ValueError, match="'\\*ankle\\*' matches none of the actuated joints: "
                     "abdomen_z, right_hip_x, right_knee, left_hip_x, left_elbow"):
    fall_analysis.noisy_actions(names, ["*hip*", "*ankle*"])
  assert fall_analysis.noise_on_name(["*hip*", "*knee*"], None) == "fall_analysis_on_hip_knee.json"
  assert fall_analysis.noise_on_name(["abdomen*"], 0.5) == "fall_analysis_on_abdomen_0.5.json"


def test_blind_holds_the_named_parts_at_each_seeds_running_means():
  layout = {"agent1/root_z": slice(0, 1), "agent1/contact_vel": slice(1, 3),
            "agent1/contact_ang": slice(3, 5), "agent1/actuator_force": slice(5, 7)}
  assert fall_analysis.blind_indices(layout, ["contact_*"]) == (
      [1, 2, 3, 4], ["agent1/contact_vel", "agent1/contact_ang"])
  # a part named twice counts once; the full name matches too
  assert fall_analysis.blind_indices(layout, ["agent1/actuator_force", "actuator*"]) == (
      [5, 6], ["agent1/actuator_force"])
  with pytest.raises(ValueError, match="'cfrc' matches none of the observation's parts: "
                     "agent1/root_z, agent1/contact_vel, agent1/contact_ang, "
                     "agent1/actuator_force"):
    fall_analysis.blind_indices(layout, ["actuator_force", "cfrc"])
  assert fall_analysis.blind_name(["contact_*"], "fall_analysis.json") == (
      "fall_analysis_blind_contact.json")
  assert fall_analysis.blind_name(["actuator_force", "contact_*"],
                                  "fall_analysis_deterministic.json") == (
      "fall_analysis_blind_actuator_force_contact_deterministic.json")

  def sees(params, obs, z=None, key=None, deterministic=True):  # acts what it observes
    return obs

  # two seeds with their own running means over [obs, z] (the latent's two entries last)
  mean = jnp.array([[10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0, -1.0, -1.0],
                    [20.0, 21.0, 22.0, 23.0, 24.0, 25.0, 26.0, -2.0, -2.0]])
  params = training.PolicyParams(
      normalizer=RunningStats(jnp.ones(2), mean, jnp.ones_like(mean)), policy=None)
  obs = jnp.arange(2 * 3 * 7, dtype=jnp.float32).reshape(2, 3, 7)  # [seed, env, obs]
  out = jax.vmap(fall_analysis.blinded(sees, [1, 2, 5]))(params, obs)
  for seed in range(2):
    np.testing.assert_array_equal(out[seed][:, [1, 2, 5]],
                                  np.broadcast_to(mean[seed, [1, 2, 5]], (3, 3)))
    np.testing.assert_array_equal(out[seed][:, [0, 3, 4, 6]], obs[seed][:, [0, 3, 4, 6]])


def test_the_command_blinds_the_parts_it_names_and_records_them(tmp_path, monkeypatch, capsys):
  layout = {"agent1/joint_pos": slice(0, 2), "agent1/contact_vel": slice(2, 4),
            "agent1/actuator_force": slice(4, 6)}
  count = jnp.ones(3)
  run = SimpleNamespace(spec=SimpleNamespace(seeds=(0, 1, 2), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=K, obs_indices=(0,)),
                        env=SimpleNamespace(obs_layout=layout), env_steps=1e6,
                        params=training.PolicyParams(
                            normalizer=RunningStats(count, jnp.zeros((3, 6)), jnp.ones((3, 6))),
                            policy={"w": jnp.arange(3.0)}))
  monkeypatch.setattr(fall_analysis.runs, "load_run", lambda directory: run)
  given = []

  def analyse(run, p, k, blind=None, **_):
    given.append(blind)
    return {"mi": p.policy["w"], "alive_share": p.policy["w"]}

  monkeypatch.setattr(fall_analysis, "analyse", analyse)
  fall_analysis.main([str(tmp_path), "--blind", "actuator*", "--deterministic"])
  assert given == [[4, 5]]
  written = json.loads((tmp_path / "fall_analysis_blind_actuator_deterministic.json").read_text())
  assert (written["blind"], written["blind_parts"]) == (["actuator*"], ["agent1/actuator_force"])
  for bad, says in ((["--blind", "cfrc"], "'cfrc' matches none of the observation's parts"),
                    (["--by-joints", "--blind", "actuator*"], "--blind is not its")):
    with pytest.raises(SystemExit):
      fall_analysis.main([str(tmp_path), *bad])
    assert says in capsys.readouterr().err
  # a policy that normalised nothing has no running means to hold the parts at
  run.params = run.params._replace(normalizer=RunningStats(0 * count, jnp.zeros((3, 6)),
                                                           jnp.ones((3, 6))))
  with pytest.raises(SystemExit):
    fall_analysis.main([str(tmp_path), "--blind", "actuator*"])
  assert "kept none (trained without normalize_observations)" in capsys.readouterr().err
  assert len(given) == 1


def test_a_write_killed_halfway_leaves_the_last_whole_result(tmp_path, monkeypatch):
  run = SimpleNamespace(spec=SimpleNamespace(seeds=(0, 1, 2), objective="diayn", env="point"),
                        objective=objectives.diayn(num_skills=K, obs_indices=(0,)),
                        params={"w": jnp.arange(3.0)}, env_steps=78_643_200.0)
  monkeypatch.setattr(fall_analysis.runs, "load_run", lambda directory: run)
  monkeypatch.setattr(fall_analysis, "analyse",
                      lambda run, p, k, **_: {"mi": p["w"], "alive_share": p["w"] + 1.0})
  out = tmp_path / "fall_analysis.json"
  fall_analysis.main([str(tmp_path)])
  whole = out.read_text()
  assert json.loads(whole)["per_seed"]["mi"] == [0.0, 1.0, 2.0]
  assert json.loads(whole)["env_steps"] == 78_643_200.0  # the checkpoint analysed

  def dies_halfway(obj, f, **kw):
    f.write('{"run": ')
    raise KeyboardInterrupt

  monkeypatch.setattr(fall_analysis.json, "dump", dies_halfway)
  with pytest.raises(KeyboardInterrupt):
    fall_analysis.main([str(tmp_path), "--draws", "2"])
  assert out.read_text() == whole


def _climbs(params, obs, z=None, key=None, deterministic=False):
  return obs + 1.0  # stands at 1, 2, ... 6 (the obs is the last action), then lies at 0


def test_a_dmin_row_is_split_at_the_falls_and_scored_against_its_target():
  # 8-step episodes, the last 4 scored, every state (short episodes): steps 5 and 6 (the fall)
  # stand at 5 and 6, steps 7 and 8 lie at 0. The whole episode before the fall is at 1..6.
  objective = objectives.gail(obs_indices=(0,), obs_scale=8.0)
  target = jnp.asarray(objective.spec.target.samples)[:, :1]
  run = SimpleNamespace(env=envs.episode(_FallsAtSix(), 8), policy=_climbs, objective=objective)
  params = training.PolicyParams(normalizer=None, policy={},
                                 objective=objective.init(jax.random.PRNGKey(3), 1))
  out = jax.jit(lambda k: fall_analysis.analyse_dmin(run, params, k, deterministic=True,
                                                     num_episodes=3))(jax.random.PRNGKey(0))
  ed = lambda values: float(metrics.energy_distance(
      jnp.tile(jnp.asarray(values, jnp.float32), 3)[:, None], target))
  np.testing.assert_allclose(out["energy_distance"], ed([5, 6, 0, 0]), rtol=1e-5)
  np.testing.assert_allclose(out["energy_distance_alive"], ed([5, 6]), rtol=1e-5)
  np.testing.assert_allclose(out["energy_distance_upright"], ed([1, 2, 3, 4, 5, 6]), rtol=1e-5)
  np.testing.assert_allclose(out["alive_share"], 0.5)
  np.testing.assert_allclose(out["upright_share"], 0.75)
  np.testing.assert_allclose(out["speed_upright"], 3.5, rtol=1e-6)
  np.testing.assert_allclose(out["feature_upright/0"], 3.5, rtol=1e-6)
  np.testing.assert_allclose(out["speed_after"], 0.0)
  np.testing.assert_allclose([out["end_step"], out["mean_end_step"], out["last_end_step"]], 6)
  # Braxlines' rollout stops before step 6 (every episode down at once) and scores the last 4
  # states it kept, s_2 .. s_5: 2, 3, 4, 5.
  np.testing.assert_allclose(out["braxlines_end"], 6)
  np.testing.assert_allclose(out["energy_distance_braxlines"], ed([2, 3, 4, 5]), rtol=1e-5)
  # The target's modes are -2.67 and +2.67 (1-D, scale 8): standing at 1..6, every episode is
  # mostly nearest to the positive one.
  means = np.asarray(objective.spec.target.means)[:, 0]
  positive = int(np.argmax(means))
  np.testing.assert_allclose(out[f"episode_mode_share_upright/{positive}"], 1.0)
  np.testing.assert_allclose(out[f"episode_mode_share_upright/{1 - positive}"], 0.0)
  # The discriminator's logit over the target's samples of each mode (here: by sign), and over
  # the states before the fall (1 .. 6).
  logit = jax.vmap(objective.spec.logit, (None, 0))
  of = lambda x: float(logit(params.objective, jnp.asarray(x, jnp.float32)).mean())
  t = np.asarray(target)
  np.testing.assert_allclose(out[f"logit_mode/{positive}"], of(t[t[:, 0] > 0]), rtol=1e-5)
  np.testing.assert_allclose(out[f"logit_mode/{1 - positive}"], of(t[t[:, 0] < 0]), rtol=1e-5)
  np.testing.assert_allclose(out["logit_upright"], of(np.arange(1.0, 7.0)[:, None]), rtol=1e-5)
  assert abs(out[f"logit_mode/{positive}"] - out[f"logit_mode/{1 - positive}"]) > 1e-3


def test_noise_on_reaches_the_dmin_rollout():
  # The states before the fall are the actions: noise on no action leaves each at the mean,
  # tanh(0.3); noise on the one action spreads them.
  objective = objectives.gail(obs_indices=(0,), obs_scale=8.0)
  run = SimpleNamespace(env=envs.episode(_FallsAtSix(), 8), policy=_tanh_gaussian,
                        objective=objective)
  params = training.PolicyParams(normalizer=None, policy={},
                                 objective=objective.init(jax.random.PRNGKey(3), 1))
  shaken = lambda where: jax.jit(lambda k: fall_analysis.analyse_dmin(
      run, params, k, deterministic=False, num_episodes=3, noise_on=where))(jax.random.PRNGKey(0))
  np.testing.assert_allclose(shaken(np.array([False]))["feature_upright/0"], np.tanh(0.3),
                             rtol=1e-5)
  assert abs(float(shaken(np.array([True]))["feature_upright/0"]) - np.tanh(0.3)) > 0.05
  assert fall_analysis._noisy_policy(run, None, None) is _tanh_gaussian


def _metrics_rows(points, noise=None):
  """metrics.csv rows from ``{env steps: {seed: (alive share, MI)}}``, with the policy's entropy
  ``noise(env steps, seed)`` where given."""
  return [{"seed": str(k), "env_steps": str(s), "eval/alive_share": str(a), "eval/mi": str(m),
           **({"policy/entropy": str(noise(s, k))} if noise else {})}
          for s, at in points.items() for k, (a, m) in at.items()]


# Four seeds on the line MI = 0.1 + 1.5 x alive share; their mean alive share is 0.2, 0.3, 0.4 at
# 10, 20 and 30 M env steps (0.1 per 10 M). An evaluation at 5 M that one seed misses is left out.
_ON_THE_LINE = {
    s: {k: (m + d, 0.1 + 1.5 * (m + d)) for k, d in enumerate((-0.05, -0.02, 0.02, 0.05))}
    for s, m in ((10e6, 0.2), (20e6, 0.3), (30e6, 0.4))}
_ON_THE_LINE[5e6] = {0: (0.9, 0.0), 1: (0.1, 3.0)}


def test_the_trend_fits_the_mi_to_the_alive_share_and_extrapolates_the_share():
  trend = fall_analysis.alive_trend(_metrics_rows(_ON_THE_LINE))
  assert (trend.since, trend.last_step, trend.fit.points) == (10e6, 30e6, 12)
  np.testing.assert_allclose([trend.fit.intercept, trend.fit.slope, trend.fit.r], [0.1, 1.5, 1.0])
  np.testing.assert_allclose([trend.alive_last, trend.alive_rate], [0.4, 0.1])
  # MI 1.0 needs the share at 0.6: 0.2 above the last mean, two windows of 10 M at 0.1 each.
  np.testing.assert_allclose(trend.fit.alive_for(1.0), 0.6)
  np.testing.assert_allclose(trend.steps_for(1.0), 50e6)
  assert trend.steps_for(0.4) == 30e6  # already there
  later = fall_analysis.alive_trend(_metrics_rows(_ON_THE_LINE), since=15e6)
  assert (later.since, later.fit.points) == (20e6, 8)
  assert trend.policy_entropy is None  # not logged
  noisy = fall_analysis.alive_trend(_metrics_rows(_ON_THE_LINE, lambda s, k: s / 1e7 + k))
  np.testing.assert_allclose(noisy.policy_entropy, [1.0 + 1.5, 3.0 + 1.5])  # seeds add 0..3


def test_a_share_that_does_not_rise_never_reaches_the_paper():
  flat = {s: {k: (a, 0.1 + 1.5 * a) for k, a in enumerate((0.2, 0.4))} for s in (1e6, 2e6)}
  trend = fall_analysis.alive_trend(_metrics_rows(flat))
  assert abs(trend.alive_rate) < 1e-12 and trend.steps_for(1.0) == float("inf")


def test_one_least_squares_line_serves_both_fits():
  rng = np.random.default_rng(0)
  x = rng.uniform(0.0, 1.0, 50)
  y = 0.3 - 2.0 * x + rng.normal(0.0, 0.1, 50)
  np.testing.assert_allclose(fall_analysis.least_squares(x, y), np.polyfit(x, y, 1))
  # y that does not change has no slope at all, whatever x's sums round to
  assert fall_analysis.least_squares(x, np.full(50, 0.25)) == (0.0, 0.25)
  fit = fall_analysis.fit_alive(x, y)
  np.testing.assert_allclose([fit.slope, fit.intercept], np.polyfit(x, y, 1))


def test_the_trend_names_what_it_cannot_fit():
  with pytest.raises(ValueError, match="needs 2"):
    fall_analysis.alive_trend(_metrics_rows(_ON_THE_LINE), since=25e6)
  with pytest.raises(ValueError, match="no eval/alive_share"):
    fall_analysis.alive_trend([{"seed": "0", "env_steps": "1", "eval/mi": "0.5"}])
  with pytest.raises(ValueError, match="nothing to fit"):
    fall_analysis.fit_alive([0.3, 0.3, 0.3], [0.1, 0.2, 0.3])


def test_the_trend_command_writes_both_fits(tmp_path, monkeypatch):
  import csv
  run = tmp_path / "run"
  run.mkdir()
  with open(run / "metrics.csv", "w", newline="") as f:
    writer = csv.DictWriter(f, ["seed", "env_steps", "eval/alive_share", "eval/mi",
                                "policy/entropy"])
    writer.writeheader()
    writer.writerows(_metrics_rows(_ON_THE_LINE, lambda s, k: s / 1e7))
  evals = []  # a file of any name, and a run directory holding an eval.json
  for name, alive in (("a.json", [0.2, 0.4]), ("b/eval.json", [0.5, 0.7])):
    (tmp_path / name).parent.mkdir(exist_ok=True)
    (tmp_path / name).write_text(json.dumps({"per_seed": {
        "eval/alive_share": alive, "eval/mi": [2.0 * a - 0.2 for a in alive]}}))
    evals.append(str(tmp_path / name.replace("/eval.json", "")))
  monkeypatch.setattr(fall_analysis.runs, "read_spec",
                      lambda directory: SimpleNamespace(env="humanoid", objective="diayn"))
  assert fall_analysis.main([str(run), "--trend", "--evals", *evals]) == 0
  out = json.loads((run / "alive_trend.json").read_text())
  paper_mi = fall_analysis.ablations.paper_tables.PAPER["humanoid"]["diayn"]["eval/mi"][0]
  np.testing.assert_allclose(out["quick"]["slope"], 1.5)
  np.testing.assert_allclose(out["policy_entropy"], [1.0, 3.0])
  np.testing.assert_allclose(out["alive_for_paper_mi"], (paper_mi - 0.1) / 1.5)
  assert out["protocol"]["points"] == 4 and out["protocol"]["evaluations"] == evals
  np.testing.assert_allclose([out["protocol"]["slope"], out["protocol"]["intercept"]], [2.0, -0.2])
  np.testing.assert_allclose(out["protocol"]["alive_for_paper_mi"], (paper_mi + 0.2) / 2.0)
  np.testing.assert_allclose(out["protocol"]["alive_mean"], 0.45)
  (tmp_path / "c.json").write_text(json.dumps({"per_seed": {"eval/mi": [0.5]}}))
  for bad in (["--evals", evals[0]], ["--since", "5"], ["--trend", "--seeds", "0"],
              ["--trend", "--evals", str(tmp_path / "c.json")],
              ["--trend", "--evals", str(tmp_path / "missing.json")]):
    with pytest.raises(SystemExit):
      fall_analysis.main([str(run), *bad])


def _analysis(directory, name, alive, mi, **flags):
  directory.mkdir(parents=True, exist_ok=True)
  (directory / name).write_text(json.dumps({
      "seeds": [0, 1], "deterministic": False, **flags,
      "per_seed": {"alive_share": alive, "mi": mi, "mi_alive": [m + 0.5 for m in mi]}}))


def _dmin_analyses(directory, *names):
  """``directory`` with a D-min run's analysis (an energy distance, no MI) under each name."""
  directory.mkdir(parents=True)
  for name in names:
    (directory / name).write_text(json.dumps(
        {"seeds": [0], "deterministic": False, "per_seed": {"energy_distance": [1.0]}}))
  return directory


def test_the_noise_curve_reads_each_analysis_at_its_scale_and_draws_the_runs_side_by_side(
    tmp_path, capsys):
  longer, row = tmp_path / "longer", tmp_path / "row"
  _analysis(longer, "fall_analysis.json", [0.5, 0.6], [0.6, 0.7])  # the protocol: scale 1
  _analysis(longer, "fall_analysis_deterministic.json", [0.9, 0.7], [1.5, 1.7], deterministic=True)
  _analysis(longer, "fall_analysis_noise_0.5.json", [0.8, 0.8], [1.1, 1.3], noise_scale=0.5)
  _analysis(longer, "fall_analysis_other.json", [0.0, 0.0], [0.0, 0.0])  # not an analysis it reads
  _analysis(row, "fall_analysis.json", [0.4, 0.4], [0.4, 0.6])
  _analysis(row, "fall_analysis_deterministic.json", [0.7, 0.7], [1.3, 1.3], deterministic=True)
  (longer / "diayn_config.json").write_text(json.dumps({"env": "humanoid", "objective": "diayn"}))
  curve = fall_analysis.noise_curve(str(longer))
  assert list(curve) == [0.0, 0.5, 1.0]
  assert curve[0.5]["alive_share"] == [0.8, 0.8] and curve[1.0]["mi"] == [0.6, 0.7]
  assert fall_analysis._row_in(str(longer)) == ("humanoid", "diayn")
  assert fall_analysis._row_in(str(row)) is None
  assert fall_analysis.main([str(longer), "--noise-curve", "--against", str(row),
                             "--labels", "203 M", "105 M"]) == 0
  table = capsys.readouterr().out
  assert "| 203 M | 0.5 | 0.800 +- 0.000 | 1.200 +- 0.100 | 1.700 +- 0.100 |" in table
  assert "| 105 M | 1 | 0.400 +- 0.000 | 0.500 +- 0.100 | 1.000 +- 0.100 |" in table
  assert (longer / "noise_curve.png").stat().st_size > 10_000


def test_the_noise_curve_names_what_it_cannot_draw(tmp_path):
  one = tmp_path / "one"
  _analysis(one, "fall_analysis.json", [0.5, 0.6], [0.6, 0.7])
  with pytest.raises(ValueError, match="two noise scales at least; it has fall_analysis.json"):
    fall_analysis.noise_curve(str(one))
  twice = tmp_path / "twice"
  _analysis(twice, "fall_analysis.json", [0.5, 0.6], [0.6, 0.7])
  _analysis(twice, "fall_analysis_noise_1.json", [0.5, 0.6], [0.6, 0.7], noise_scale=1.0)
  with pytest.raises(ValueError, match="both at noise scale 1"):
    fall_analysis.noise_curve(str(twice))
  dmin = _dmin_analyses(tmp_path / "dmin", "fall_analysis.json")
  with pytest.raises(ValueError, match="holds no MI"):
    fall_analysis.noise_curve(str(dmin))
  partial = tmp_path / "partial"
  _analysis(partial, "fall_analysis.json", [0.5, 0.6], [0.6, 0.7])
  _analysis(partial, "fall_analysis_noise_0.5.json", [0.8, 0.8], [1.1, 1.3], noise_scale=0.5,
            noise_on=["*hip*"])
  with pytest.raises(ValueError, match="--noise-on"):
    fall_analysis.noise_curve(str(partial))
  _analysis(one, "fall_analysis_deterministic.json", [0.9, 0.7], [1.5, 1.7], deterministic=True)
  assert fall_analysis.main([str(one), "--noise-curve"]) == 0  # two scales now
  (one / "diayn_config.json").write_text("{not json")
  with pytest.raises(ValueError, match="diayn_config.json is unreadable"):
    fall_analysis._row_in(str(one))
  for bad in (["--against", str(one)], ["--labels", "a"],  # without --noise-curve
              ["--noise-curve", "--labels", "a", "b"],  # two names, one directory
              ["--noise-curve", "--against", str(one), "--labels", "a", "a"],
              ["--noise-curve", "--deterministic"], ["--noise-curve", "--trend"],
              ["--noise-curve", "--draws", "3"], ["--noise-curve", "--since", "5"],
              ["--noise-curve", "--noise-on", "*hip*"], ["--trend", "--noise-on", "*hip*"],
              ["--noise-curve", "--against", str(tmp_path / "x" / "one")],  # two named "one"
              ["--noise-curve", "--against", str(twice)], ["--noise-curve"]):  # its config
    with pytest.raises(SystemExit):
      fall_analysis.main([str(one), *bad])


def test_the_noise_by_joints_lies_between_the_mean_actions_and_the_protocol(tmp_path, capsys):
  run = tmp_path / "run"
  _analysis(run, "fall_analysis_deterministic.json", [0.9, 0.8], [1.5, 1.7], deterministic=True)
  _analysis(run, "fall_analysis.json", [0.5, 0.3], [0.6, 0.7])
  _analysis(run, "fall_analysis_on_hip_knee.json", [0.6, 0.6], [0.9, 0.8],
            noise_on=["*hip*", "*knee*"], noisy_joints=["a/hip", "a/knee", "b/hip", "b/knee"])
  _analysis(run, "fall_analysis_on_abdomen.json", [0.8, 0.8], [1.2, 1.0], noise_on=["abdomen*"],
            noisy_joints=["abdomen_z"])
  _analysis(run, "fall_analysis_on_abdomen_0.5.json", [0.0, 0.0], [0.0, 0.0], noise_scale=0.5,
            noise_on=["abdomen*"], noisy_joints=["abdomen_z"])  # another scale: not a row
  rows = fall_analysis.joint_noise(str(run))
  assert [(label, count) for label, count, _ in rows] == [
      ("none (the mean actions)", 0), ("abdomen", 1), ("hip, knee", 4),
      ("every action (the protocol)", None)]
  assert fall_analysis.main([str(run), "--by-joints"]) == 0
  table = capsys.readouterr().out
  # the legs' row: alive 0.6 in both seeds, 0.25 below the mean actions' 0.85
  assert "| hip, knee | 4 | 0.600 +- 0.000 | -0.250, " in table
  assert "| none (the mean actions) | 0 | 0.850 +- 0.050 |  | 1.600 +- 0.100 |" in table
  assert (run / "joint_noise.png").stat().st_size > 10_000
  with pytest.raises(SystemExit):  # 0 is a scale given, as much as 0.5 is
    fall_analysis.main([str(run), "--by-joints", "--noise-scale", "0"])
  assert "--noise-scale is not its" in capsys.readouterr().err


def test_the_noise_by_joints_names_what_it_cannot_read(tmp_path):
  run = tmp_path / "run"
  _analysis(run, "fall_analysis.json", [0.5, 0.4], [0.6, 0.7])
  with pytest.raises(ValueError, match="needs fall_analysis_deterministic.json"):
    fall_analysis.joint_noise(str(run))
  dmin = _dmin_analyses(tmp_path / "dmin", "fall_analysis.json",
                        "fall_analysis_deterministic.json")
  with pytest.raises(ValueError, match="holds no MI"):
    fall_analysis.joint_noise(str(dmin))
  _analysis(run, "fall_analysis_deterministic.json", [0.9, 0.8], [1.5, 1.7], deterministic=True)
  with pytest.raises(ValueError, match="holds no fall_analysis_on_"):
    fall_analysis.joint_noise(str(run))
  (run / "fall_analysis_on_knee.json").write_text(json.dumps({
      "seeds": [0, 3], "deterministic": False, "noise_on": ["*knee*"], "noisy_joints": ["k"],
      "per_seed": {"alive_share": [0.5, 0.5], "mi": [1.0, 1.0], "mi_alive": [1.2, 1.2]}}))
  with pytest.raises(ValueError, match="seeds \\[0, 3\\], the protocol's analysis \\[0, 1\\]"):
    fall_analysis.joint_noise(str(run))
  for bad in (["--by-joints", "--noise-curve"], ["--by-joints", "--noise-on", "*knee*"],
              ["--by-joints", "--seeds", "0"], ["--by-joints"]):  # the last: the seeds above
    with pytest.raises(SystemExit):
      fall_analysis.main([str(run), *bad])
