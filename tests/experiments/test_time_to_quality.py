"""benchmarks/time_to_quality.py: which seeds an arm trains; a plot that names each arm's recipe."""

import pytest

from tests.experiments import load_benchmark

ttq = load_benchmark("time_to_quality")  # it imports paper_tables from beside it


def test_an_arm_trains_the_seeds_from_first_seed_with_the_papers_objective_settings():
  spec = ttq.arm_spec("ant", "diayn", 16384, 2, 1_000_000, 4, {"learning_rate": 1e-3},
                      first_seed=3)
  assert spec.seeds == (3, 4)
  assert spec.ppo == {"num_envs": 16384, "num_timesteps": 1_000_000, "num_evals": 4,
                      "learning_rate": 1e-3}
  assert spec.objective == "diayn"
  assert spec.objective_options == {"obs_indices": "vel", "obs_scale": 5.0, "spectral_norm": True}
  assert ttq.arm_spec("ant", "diayn", 2048, 1, 1, 1, {}).seeds == (0,)


def test_the_plot_names_each_arms_envs_batch_and_episode_starts(tmp_path):
  def result(num_envs, staggered, values, minibatches=None):
    rows = [{"wall_s": 10.0 * (i + 1), "env_steps": 1e6 * (i + 1), "values": v,
             "mean": sum(v) / len(v)} for i, v in enumerate(values)]
    return {"objective": "diayn", "env": "ant", "num_envs": num_envs, "label": "",
            "metric": "eval/mi", "threshold": 1.115, "rows": rows,
            "ppo": {"batch_size": 1024, "starts_staggered": staggered,
                    **({"num_minibatches": minibatches} if minibatches else {})}}
  path = tmp_path / "ttq.png"
  labels = ttq.plot([result(16384, True, [[0.5], [1.2]], minibatches=32),
                     result(2048, False, [[0.3], [0.9]]),
                     {**result(4096, None, [[0.1]]), "label": "lr2"}], str(path))
  assert labels == ["16,384 envs, batch 1,024 x 32, staggered starts",
                    "2,048 envs, batch 1,024, starts in step", "4,096 envs, batch 1,024, lr2"]
  assert path.stat().st_size > 10_000


def test_objective_options_go_over_the_papers_and_a_bad_one_is_named_before_any_arm(
    monkeypatch, capsys, tmp_path):
  spec = ttq.arm_spec("ant", "gail", 2048, 1, 1, 1, {}, options={"gradient_penalty_weight": 1.0})
  assert spec.objective_options["gradient_penalty_weight"] == 1.0
  assert spec.objective_options["obs_scale"] == 8.0  # the paper's GAIL settings stay
  trained = []
  monkeypatch.setattr(ttq, "run_arm", lambda *a: trained.append(a))
  for options, message in (('{"gradient_penalty_weihgt": 1}',
                            "--options for gail: objective 'gail': unknown option(s) "
                            "['gradient_penalty_weihgt']; valid options are"),
                           ("[1]", "--options: a JSON object of objective options"),
                           ("{gp: 1}", "--options: not JSON")):
    monkeypatch.setattr("sys.argv", ["time_to_quality.py", "--objectives", "gail", "--options",
                                     options, "--out", str(tmp_path)])
    with pytest.raises(SystemExit):
      ttq.main()
    assert message in capsys.readouterr().err
  assert not trained
