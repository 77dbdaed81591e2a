"""The ``blx`` command end to end on CPU with tiny budgets: train -> eval -> render -> sweep, the
files they write, and the bad-input cases (one line, exit status 2)."""

from __future__ import annotations

import csv
import dataclasses
import inspect
import io
import json
import os
import re
import shutil
import subprocess
import sys

import jax
import numpy as np
import pytest

from blx import metrics
from blx.experiments import cli, sweep

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TINY_CONFIG = dict(num_envs=16, batch_size=8, num_minibatches=4, unroll_length=5,
                   num_evals=2, num_eval_envs=4, policy_hidden=(16, 16), value_hidden=(16, 16))
TINY = [arg for k, v in TINY_CONFIG.items() for arg in ("--config", f"{k}={v!r}".replace(" ", ""))]
TINY += ["--steps", "1600", "--env-param", "episode_length=20"]  # the episode is the env's


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
  out = str(tmp_path_factory.mktemp("runs") / "diayn")
  rc = cli.main(["train", "--num-skills", "3", "--seeds", "0,1", "--out", out, *TINY])
  assert rc == 0
  return out


def test_train_writes_a_complete_run_directory(trained):
  names = set(os.listdir(trained))
  assert {"config.json", "metrics.csv", "eval.json", "checkpoint", "plots"} <= names
  plots = set(os.listdir(os.path.join(trained, "plots")))
  assert {"training_curves.png", "skills.png", "paths.png"} <= plots
  config = json.load(open(os.path.join(trained, "config.json")))
  assert config["env"] == "point" and config["objective"] == "diayn"
  assert config["objective_options"] == {"num_skills": 3}
  # eval.json names the machine that evaluated it (here the one that trained it)
  machine = json.load(open(os.path.join(trained, "eval.json")))["evaluated_on"]
  trainer = json.load(open(os.path.join(trained, "provenance.json")))["segments"][-1]
  assert machine["platform"] == jax.devices()[0].platform == trainer["platform"]
  assert machine["versions"] == trainer["versions"] and machine["date"] >= trainer["started"]
  # and the LGR goals both drew: the paper's, as the evaluators do by default
  assert machine["lgr_goals"] == trainer["lgr_goals"] == "braxlines" == inspect.signature(
      metrics.mimax_evaluator).parameters["goal_draw"].default
  assert config["desc"]["components"]["agent1"]["component"] == "point"
  rows = list(csv.DictReader(open(os.path.join(trained, "metrics.csv"))))
  # 2 evaluations x 2 seeds, with finite rewards.
  assert len(rows) == 4 and {r["seed"] for r in rows} == {"0", "1"}
  assert all(np.isfinite(float(r["eval/episode_reward"])) for r in rows)
  # eval.json says how far the evaluated parameters trained: here, to the run's end
  assert json.load(open(os.path.join(trained, "eval.json")))["env_steps"] == float(
      rows[-1]["env_steps"]) == 1600
  # Steps/s and the ETA leave compilation out; "time" is the wall time since the start.
  for r in rows:
    steps, wall, compile_s = float(r["env_steps"]), float(r["time"]), float(r["compile_seconds"])
    assert 0 < compile_s < wall
    np.testing.assert_allclose(float(r["steps_per_second"]), steps / (wall - compile_s), rtol=1e-6)
    np.testing.assert_allclose(float(r["eta_seconds"]),
                               (float(r["total_steps"]) - steps) / (steps / (wall - compile_s)),
                               rtol=1e-6)


def test_eval_reports_the_mimax_metrics_as_json(trained, capsys):
  assert cli.main(["eval", trained, "--json"]) == 0
  result = json.loads(capsys.readouterr().out)
  for key in ("eval/mi", "eval/entropy", "eval/lgr", "eval/coverage", "eval/episode_reward"):
    values = result["per_seed"][key]
    assert len(values) == 2 and all(np.isfinite(values)), key
  # MI is bounded by H(s) and by log K (3 skills).
  assert 0 <= result["summary"]["eval/mi"]["mean"] <= np.log(3) + 1e-5
  assert result["summary"]["eval/mi"]["mean"] <= result["summary"]["eval/entropy"]["mean"] + 1e-5


def _eval_keeping_eval_json(trained, capsys, *args):
  """``blx eval TRAINED ARGS --json``: its result, what it told stderr and the run's eval.json,
  which it must leave as it was."""
  path = os.path.join(trained, "eval.json")
  before = open(path).read()
  assert cli.main(["eval", trained, *args, "--json"]) == 0
  out = capsys.readouterr()
  assert open(path).read() == before
  return json.loads(out.out), out.err, json.loads(before)


def test_eval_with_several_keys_reports_the_evaluations_own_noise_and_keeps_eval_json(trained,
                                                                                       capsys):
  result, told, own = _eval_keeping_eval_json(trained, capsys, "--key-seeds", "0,1,2")
  assert "eval.json (key 0) is left as it was" in told
  assert result["key_seeds"] == [0, 1, 2] and len(result["per_key"]) == 3
  # key 0 is the evaluation eval.json holds; the other keys sample other episodes
  assert result["per_key"][0]["per_seed"] == own["per_seed"]
  lgr = [k["per_seed"]["eval/lgr"] for k in result["per_key"]]
  assert lgr[1] != lgr[0] and lgr[2] != lgr[1]
  row = result["across_keys"]["eval/lgr"]
  means = np.mean(lgr, axis=1)
  np.testing.assert_allclose(row["mean_per_key"], means, rtol=1e-6)
  np.testing.assert_allclose(row["std_of_mean"], np.std(means), rtol=1e-6)
  np.testing.assert_allclose(row["seed_std"], np.std(lgr, axis=0).mean(), rtol=1e-6)
  assert cli.main(["eval", trained, "--key-seeds", "0,1"]) == 0  # the table, one line a metric
  lines = capsys.readouterr().out.splitlines()
  assert any(line.startswith("eval/lgr ") and "per seed ±" in line for line in lines)


def test_eval_with_the_mean_action_scores_blxs_old_protocol_and_keeps_eval_json(trained, capsys):
  # The run evaluates with sampled actions (blx's default, Braxlines' PPO's); --eval-actions mean
  # scores the return episodes with the mean action, and leaves eval.json as the run's own.
  mean, told, own = _eval_keeping_eval_json(trained, capsys, "--eval-actions", "mean")
  assert "eval_actions='mean'" in told and mean["eval_actions"] == "mean"
  own = own["per_seed"]
  # the return episodes act otherwise; the paper's evaluator, which samples anyway, is unchanged
  assert not np.allclose(mean["per_seed"]["eval/episode_reward"], own["eval/episode_reward"])
  for metric in ("eval/mi", "eval/entropy", "eval/lgr"):
    np.testing.assert_allclose(mean["per_seed"][metric], own[metric], rtol=1e-5, atol=1e-6)
  # the run's own way of acting is its ordinary evaluation
  assert cli.main(["eval", trained, "--eval-actions", "sampled", "--json"]) == 0
  assert json.loads(capsys.readouterr().out)["per_seed"] == own


def test_an_unfinished_run_is_evaluated_where_it_stands_and_its_sweep_trains_it_on(
    tmp_path, capsys, monkeypatch):
  # A sweep's point training in segments (2 per chunk of 5 iterations: 3 + 2), stopped as a device
  # call's time limit stops it, after the checkpoint of its second chunk's first segment: its
  # parameters trained 8 iterations, past its last evaluation's 5.
  from blx.experiments import runs
  from blx.training import checkpoint
  monkeypatch.setenv("BLX_CHECKPOINT_SEGMENTS", "2")
  saves, save, kept = [], checkpoint.save, []

  def save_then_stop(directory, tree, meta, **kwargs):
    save(directory, tree, meta, **kwargs)
    saves.append(meta["chunk"])
    # what provenance.json said when the chunk's end was saved: a process killed there, without
    # a word, leaves it so
    if len(saves) == 2:
      kept.extend(s.to_env_steps for s in runs.read_provenance(os.path.dirname(directory)))
    if len(saves) == 3:
      raise KeyboardInterrupt

  config = {**TINY_CONFIG, "policy_hidden": [[16, 16]], "value_hidden": [[16, 16]]}
  spec = {"name": "stopped", "env": "point", "objective": "gcrl", "seeds": [0], "steps": 1600,
          "config": config, "env_params": {"episode_length": 20}}
  out = str(tmp_path / "sweep")
  monkeypatch.setattr(checkpoint, "save", save_then_stop)
  bar = cli._Progress(io.StringIO())
  with pytest.raises(KeyboardInterrupt):
    sweep.run_sweep(spec, out, progress=bar)
  monkeypatch.setattr(checkpoint, "save", save)
  [point] = [os.path.join(out, d) for d in os.listdir(out) if os.path.isdir(os.path.join(out, d))]
  per_iteration = 1600 / 10
  # the progress bar shows the first chunk's first segment, checkpointed, then the chunk's end
  shown = bar.stream.getvalue().splitlines()
  assert len(shown) == 2
  assert shown[0].startswith("[") and " 480/1,600 steps " in shown[0]
  assert shown[0].endswith("(3 of 5 iterations of chunk 1; checkpointed)")
  assert " 800/1,600 steps " in shown[1]
  # provenance.json followed the segment's checkpoint before the chunk ended
  assert kept == [3 * per_iteration]
  rows = list(csv.DictReader(open(os.path.join(point, "metrics.csv"))))
  assert [float(r["env_steps"]) for r in rows] == [5 * per_iteration]
  # provenance.json counts the steps the process kept: to its last checkpoint, not evaluation
  [stopped] = runs.read_provenance(point)
  assert (stopped.from_env_steps, stopped.to_env_steps) == (0.0, 8 * per_iteration)

  # blx eval scores it as it stands, names how far it trained, and writes no eval.json
  capsys.readouterr()
  assert cli.main(["eval", point, "--json"]) == 0
  captured = capsys.readouterr()
  assert json.loads(captured.out)["env_steps"] == 8 * per_iteration
  assert "is unfinished (1 of 2 chunks and 3 iterations of the next)" in captured.err
  assert "eval.json" not in os.listdir(point)
  # evaluated with other keys or another way of acting, it is still named unfinished
  assert cli.main(["eval", point, "--key-seeds", "0,1", "--json"]) == 0
  captured = capsys.readouterr()
  assert json.loads(captured.out)["env_steps"] == 8 * per_iteration
  assert "is unfinished (1 of 2 chunks and 3 iterations of the next)" in captured.err
  own = runs.load_run(point).config.eval_actions
  other = {"mean": "sampled", "sampled": "mean"}[own]
  assert cli.main(["eval", point, "--eval-actions", other, "--json"]) == 0
  captured = capsys.readouterr()
  assert json.loads(captured.out)["env_steps"] == 8 * per_iteration
  assert f"eval_actions={other!r}" in captured.err
  assert "is unfinished (1 of 2 chunks and 3 iterations of the next)" in captured.err
  assert cli.main(["eval", point]) == 0
  assert "seeds [0], trained 1,280 env steps per seed" in capsys.readouterr().out
  run = runs.load_run(point)
  assert not run.finished
  with pytest.raises(runs.RunError, match="is unfinished .* eval.json is written once"):
    runs.write_eval(run)

  # An eval.json beside it (as blx eval wrote one before) does not end the point: the sweep
  # trains it on to its end, and the finished run's eval.json replaces it.
  with open(os.path.join(point, "eval.json"), "w") as f:
    json.dump(runs.evaluation(run), f)
  rows_out = sweep.run_sweep(spec, out, progress=print)
  assert "its eval.json scored an unfinished run (1 of 2 chunks and 3 iterations of the next)" in (
      capsys.readouterr().out)
  rows = list(csv.DictReader(open(os.path.join(point, "metrics.csv"))))
  assert [float(r["env_steps"]) for r in rows] == [5 * per_iteration, 1600]
  final = json.load(open(os.path.join(point, "eval.json")))
  assert final["env_steps"] == 1600 and rows_out[0]["summary"] == final["summary"]
  assert runs.load_run(point).finished
  # and the process that went on took the run up where the checkpoint stood, within the chunk
  assert [(s.from_env_steps, s.to_env_steps) for s in runs.read_provenance(point)] == [
      (0.0, 8 * per_iteration), (8 * per_iteration, 1600.0)]


def test_eval_metrics_only_gives_the_evaluators_values_without_the_return_episodes(trained,
                                                                                    capsys):
  assert cli.main(["eval", trained, "--key-seeds", "0", "--metrics-only", "--json"]) == 0
  per_seed = json.loads(capsys.readouterr().out)["per_key"][0]["per_seed"]
  full = json.load(open(os.path.join(trained, "eval.json")))["per_seed"]  # key 0, everything
  assert "eval/episode_reward" in full and "eval/episode_reward" not in per_seed
  assert {"eval/mi", "eval/entropy", "eval/lgr"} <= set(per_seed)
  for metric, values in per_seed.items():
    np.testing.assert_allclose(values, full[metric], rtol=1e-5, atol=1e-6, err_msg=metric)


def test_eval_reads_a_checkpoint_with_the_quick_protocol_under_the_same_keys(trained, capsys,
                                                                              monkeypatch):
  # --eval-protocol quick: the evaluator of the curves logged during training (fewer episodes),
  # under the same keys as the final one; final (the default) is eval.json's own evaluation.
  from blx.experiments import runs
  built = []
  real = runs.evaluator_for
  monkeypatch.setattr(runs, "evaluator_for", lambda env, objective, quick=False: (
      built.append(quick) or real(env, objective, quick=quick)))
  final, _, own = _eval_keeping_eval_json(trained, capsys, "--key-seeds", "0", "--metrics-only",
                                          "--eval-protocol", "final")
  quick, told, _ = _eval_keeping_eval_json(trained, capsys, "--key-seeds", "0", "--metrics-only",
                                           "--eval-protocol", "quick")
  assert built == [False, True]
  assert (final["eval_protocol"], quick["eval_protocol"]) == ("final", "quick")
  assert "the quick protocol's sizes" in told
  np.testing.assert_allclose(final["per_key"][0]["per_seed"]["eval/mi"],
                             own["per_seed"]["eval/mi"], rtol=1e-5)
  assert quick["per_key"][0]["per_seed"]["eval/mi"] != final["per_key"][0]["per_seed"]["eval/mi"]
  with pytest.raises(ValueError, match="protocol 'slow': valid are quick, final"):
    runs.evaluate_run_keys(runs.load_run(trained), [0], protocol="slow")


def test_eval_metrics_only_refuses_an_objective_without_an_evaluator(trained, monkeypatch):
  from blx.experiments import runs
  run = runs.load_run(trained)
  monkeypatch.setattr(runs, "evaluator_for", lambda env, objective, quick=False: None)
  with pytest.raises(ValueError, match="objective 'diayn' has no evaluator, so its only metrics"):
    runs.evaluate_run_keys(run, [0], metrics_only=True)


def test_load_run_rebuilds_env_objective_and_params(trained):
  import blx
  run = blx.load_run(trained)
  assert run.objective.name == "diayn" and run.objective.latent_size == 3
  assert run.env.observation_size == 4
  # Rebuilt from its desc, the env keeps the episode it was trained with (20, not point's 50).
  assert run.env.episode_length == 20 and __import__("blx").envs.episode_steps(run.env) == 20
  leaves = [np.asarray(x) for x in __import__("jax").tree.leaves(run.params.policy)]
  assert all(x.shape[0] == 2 for x in leaves)  # the seed axis


def test_render_writes_a_video_with_frames_of_the_right_size(trained, tmp_path):
  out = str(tmp_path / "video.mp4")
  env = {**os.environ, "PYTHONPATH": ROOT}
  proc = subprocess.run([sys.executable, "-m", "blx.experiments.cli", "render", trained,
                         "--skills", "0,2", "--width", "96", "--height", "64", "--out", out],
                        capture_output=True, text=True, env=env, timeout=600)
  if "rendering needs an OpenGL backend" in proc.stderr:
    pytest.skip("no headless OpenGL on this machine (install libegl1 or libosmesa6)")
  assert proc.returncode == 0, proc.stderr[-2000:]
  import imageio.v3 as iio
  frames = iio.imread(out)
  # 2 skills x (20 steps + the first frame), 64 x 96 RGB, not blank.
  assert frames.shape == (42, 64, 96, 3)
  assert frames.std() > 1.0


def _cli(args, gl, timeout=600):
  env = {**os.environ, "PYTHONPATH": ROOT, "MUJOCO_GL": gl}
  env.pop("PYOPENGL_PLATFORM", None)
  return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                        timeout=timeout)


def test_only_rendering_needs_opengl(trained):
  # A MUJOCO_GL that names no backend breaks a plain `import mujoco` ...
  plain = _cli(["-c", "import mujoco"], gl="nonsense")
  assert plain.returncode != 0 and "MUJOCO_GL" in plain.stderr
  # ... but not blx: eval runs and prints its metrics,
  proc = _cli(["-m", "blx.experiments.cli", "eval", trained, "--json"], gl="nonsense")
  assert proc.returncode == 0, proc.stderr[-2000:]
  assert "eval/mi" in json.loads(proc.stdout)["summary"]
  # and render says, in one line with exit status 2, which values are valid.
  proc = _cli(["-m", "blx.experiments.cli", "render", trained, "--steps", "2"], gl="nonsense")
  assert proc.returncode == 2
  assert "Traceback" not in proc.stderr
  assert "MUJOCO_GL='nonsense' is not one of ['egl', 'glfw', 'glx', 'osmesa']" in proc.stderr


def test_a_missing_gl_library_is_named():
  import ctypes.util
  if ctypes.util.find_library("OSMesa"):
    pytest.skip("OSMesa is installed here, so MUJOCO_GL=osmesa loads")
  from blx.experiments import render
  proc = _cli(["-c", "from blx.experiments import render; render.load_gl_backend()"],
              gl="osmesa")
  assert proc.returncode != 0
  assert "GLError: rendering needs an OpenGL backend, and MUJOCO_GL=osmesa could not be loaded" \
      in proc.stderr
  assert render.GL_NEEDS["osmesa"] in proc.stderr and "libosmesa6" in render.GL_NEEDS["osmesa"]


def test_sweep_writes_one_run_per_point_and_aggregate_tables(tmp_path, capsys):
  spec = {"name": "tiny", "env": "point", "objective": ["gcrl", "gail"], "seeds": [0, 1],
          "steps": 1600, "config": dict(TINY_CONFIG), "options": {"obs_scale": 4.0},
          "env_params": {"episode_length": 20}}
  # A list is a grid axis; a list-valued setting is a one-point axis holding the list.
  spec["config"].update(policy_hidden=[[16, 16]], value_hidden=[[16, 16]])
  path = tmp_path / "spec.json"
  path.write_text(json.dumps(spec))
  out = str(tmp_path / "sweep")
  # A process may train only its share of the points (select); the table holds what exists.
  part = sweep.run_sweep(spec, out, progress=False, select=lambda name, rs: rs.objective == "gcrl")
  assert [r["name"] for r in part] == ["objective=gcrl"] and "objective=gail" not in os.listdir(out)
  assert [r["run"] for r in csv.DictReader(open(os.path.join(out, "summary.csv")))] == [
      "objective=gcrl"]
  mtime = os.path.getmtime(os.path.join(out, "objective=gcrl", "eval.json"))
  # The command trains the rest and reuses the evaluated point instead of retraining it.
  assert cli.main(["sweep", str(path), "--out", out]) == 0
  assert os.path.getmtime(os.path.join(out, "objective=gcrl", "eval.json")) == mtime
  assert {"objective=gcrl", "objective=gail"} <= set(os.listdir(out))
  assert os.path.exists(os.path.join(out, "objective=gail", "plots", "density.png"))
  assert os.path.exists(os.path.join(out, "objective=gail", "plots", "discriminator.png"))
  rows = list(csv.DictReader(open(os.path.join(out, "summary.csv"))))
  assert [r["run"] for r in rows] == ["objective=gcrl", "objective=gail"]
  assert all(r["seeds"] == "2" for r in rows)
  assert np.isfinite(float(rows[0]["MI(s,z) mean"]))
  assert float(rows[1]["-energy distance mean"]) < 0  # energy distances are positive
  md = open(os.path.join(out, "summary.md")).read()
  assert "| objective=gcrl | 2 |" in md and "±" in md
  assert "\\pm" in open(os.path.join(out, "summary.tex")).read()
  # A changed spec never reuses old results: the point says what changed and is left alone.
  spec["steps"] = 3200
  path.write_text(json.dumps(spec))
  assert cli.main(["sweep", str(path), "--out", out]) == 2
  err = capsys.readouterr().err
  assert "sweep point 'objective=gcrl'" in err and "'num_timesteps': 1600" in err, err
  assert "'num_timesteps': 3200" in err
  assert os.path.getmtime(os.path.join(out, "objective=gcrl", "eval.json")) == mtime


def test_an_interrupted_sweep_says_how_to_continue_and_exits_130(tmp_path, capsys, monkeypatch):
  path = tmp_path / "spec.json"
  path.write_text(json.dumps({"env": "point", "objective": "gcrl", "steps": 1600}))

  def interrupted(*args, **kwargs):  # a Ctrl-C (or a timeout's SIGINT) while a point trains
    raise KeyboardInterrupt

  monkeypatch.setattr(sweep, "run_sweep", interrupted)
  assert cli.main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 130
  assert f"[blx] {sweep.INTERRUPTED}" in capsys.readouterr().err


_PROGRAM = """
import atexit, sys, threading, time
from blx.experiments import cli
atexit.register(lambda: print("shutdown ran", flush=True))
def main():
  # work still in flight, which the interpreter's shutdown would wait for (as for a chunk on
  # the device): a thread that is not a daemon, asleep for ten minutes
  threading.Thread(target=time.sleep, args=(600,)).start() if sys.argv[1] == "130" else None
  print("[program] stopped", end="")  # unflushed, to a pipe
  if sys.argv[2] == "raise":  # a Ctrl-C that main does not catch
    raise KeyboardInterrupt
  return int(sys.argv[1]) if sys.argv[2] == "return" else sys.exit(int(sys.argv[2]))
cli.run_main(main)
"""


@pytest.mark.parametrize("how", ["return", "130", "raise"])
def test_run_main_ends_an_interrupted_program_at_once_with_its_output(how):
  # status 130 (returned, raised as SystemExit by ablations.py, or a Ctrl-C main let through):
  # no wait for the work in flight, and the output is flushed; the shutdown is skipped
  proc = subprocess.run([sys.executable, "-c", _PROGRAM, "130", how], capture_output=True,
                        text=True, env={**os.environ, "PYTHONPATH": ROOT}, timeout=120)
  assert proc.returncode == 130, proc.stderr[-2000:]
  assert proc.stdout == "[program] stopped"
  assert "Traceback" not in proc.stderr
  assert (proc.stderr.strip().endswith("interrupted")) == (how == "raise")


def test_run_main_exits_other_programs_with_their_status_after_the_shutdown():
  for status, how in ((0, "return"), (2, "2")):
    proc = subprocess.run([sys.executable, "-c", _PROGRAM, str(status), how],
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": ROOT},
                          timeout=120)
    assert proc.returncode == status, proc.stderr[-2000:]
    assert proc.stdout == "[program] stoppedshutdown ran\n"


_NONFINITE_PROGRAM = """
import atexit, sys, threading, time
from blx.experiments import cli
from blx.training import loop
atexit.register(lambda: print("shutdown ran", flush=True))
def main():
  if sys.argv[1] == "in-flight":  # the next chunk, still running on the device
    threading.Thread(target=time.sleep, args=(600,), name=loop.DISPATCH_THREAD,
                     daemon=True).start()
  print("[program] trained", end="")  # unflushed, to a pipe
  raise loop.NonFiniteError("non-finite loss at iteration 3 (seed 1)")
cli.run_main(main)
"""


@pytest.mark.parametrize("when", ["in-flight", "between"])
def test_run_main_ends_a_non_finite_run_with_one_line_and_status_2(when):
  # A chunk in flight when the error comes: the process ends at once, output flushed, without the
  # shutdown, which on a GPU stopped the dispatch thread inside XLA and aborted (status 134,
  # session 50); without one, the usual shutdown.
  proc = subprocess.run([sys.executable, "-c", _NONFINITE_PROGRAM, when], capture_output=True,
                        text=True, env={**os.environ, "PYTHONPATH": ROOT}, timeout=120)
  assert proc.returncode == 2, proc.stderr[-2000:]
  assert "Traceback" not in proc.stderr
  assert proc.stderr.strip().endswith("error: non-finite loss at iteration 3 (seed 1)")
  shutdown = "" if when == "in-flight" else "shutdown ran\n"
  assert proc.stdout.endswith("[program] trained" + shutdown)  # (after mjx's import notice)


def test_a_task_sweeps_table_gives_the_episode_length_beside_the_score(tmp_path):
  # Two legs flip within 240 of 1,000 steps and so score higher than four that run (session 26);
  # only the length tells.
  from blx import metrics
  from blx.objectives import presets
  family = metrics.family_of(presets.make("task"))
  summaries = {"num_legs=4": {"eval/episode_score": (-1091.0, 356.0),
                              "eval/episode_length": (996.0, 8.0)},
               "num_legs=2": {"eval/episode_score": (-772.0, 676.0),
                              "eval/episode_length": (240.0, 172.0)}}
  rows = [{"name": name, "env": "pro_ant_run", "objective": "task", "family": family.name,
           "columns": family.table, "seeds": 10,
           "summary": {k: {"mean": m, "std": sd} for k, (m, sd) in summary.items()}}
          for name, summary in summaries.items()]
  sweep.write_tables(rows, str(tmp_path))
  table = {r["run"]: r for r in csv.DictReader(open(tmp_path / "summary.csv"))}
  assert float(table["num_legs=2"]["episode score mean"]) > float(
      table["num_legs=4"]["episode score mean"])
  assert float(table["num_legs=2"]["episode length mean"]) == 240.0
  assert float(table["num_legs=4"]["episode length mean"]) == 996.0
  md = (tmp_path / "summary.md").read_text()
  assert "| run | seeds | episode reward | episode score | episode length |" in md
  assert "| num_legs=2 | 10 | - | -772.000 ± 676.000 | 240.000 ± 172.000 |" in md


@pytest.mark.parametrize("argv, message", [
    (["train", "--env", "nope"], "unknown env 'nope'; valid envs are"),
    (["train", "--objective", "dayn"], "unknown objective 'dayn'; valid objectives are"),
    (["train", "--config", "foo=1"], "unknown key(s) ['foo']; valid keys are"),
    (["train", "--config", "num_envs"], "expected key=value"),
    (["train", "--config", "episode_length=20"],
     "episode_length belong to the env, not to PPO: create the env with them"),
    (["train", "--env-param", "episode_length=0"], "episode_length must be an int in 1..2**31 - 1"),
    (["train", "--seeds", "a,b"], "expected comma-separated ints"),
    (["train", "--option", "bogus=1"], "unknown option(s) ['bogus']"),
    (["train", "--config", "learning_rate=abc"], "learning_rate must be a number, got 'abc'"),
    (["train", "--config", "learning_rate=float('nan')"], "learning_rate must be a number"),
    (["train", "--config", "reward_scaling=0"], "reward_scaling > 0"),
    (["train", "--config", "entropy_cost=-1.0"], "entropy_cost must be >= 0"),
    (["train", "--option", "logits_clip=1e999"], "logits_clip must be finite, got inf"),
    (["train", "--option", "env_reward_multiplier=1e999"], "must be finite"),
    (["train", "--option", "spectral_norm=maybe"], "spectral_norm must be True or False"),
    (["train", "--objective", "gcrl", "--option", "obs_scale=big"], "obs_scale must be a number"),
    (["train", "--num-skills", "1"], "num_skills must be an int in 2..65536 (a skill is"),
    (["eval", "/nonexistent/run"], "no run directory at"),
    (["envs", "nope"], "unknown env 'nope'"),
    (["train", "--steps", str(10**23)], "num_timesteps must be a positive int up to 2**31 - 1"),
    (["train", "--seeds", str(10**20)], "seeds are ints in 0..2**31 - 1"),
    (["train", "--seeds", "0,0"], "repeats a seed"),
    (["train", "--obs-indices", "1.5"], "obs_indices must be a name such as 'vel_xy', an int or"),
    (["render", "anyrun", "--width", "0"], "--width 0: valid sizes are 16..4096 pixels"),
    (["render", "anyrun", "--height", "100000"], "--height 100000: valid sizes are 16..4096"),
    (["render", "anyrun", "--steps", "0"], "--steps 0: give at least 1 env step"),
    (["render", "anyrun", "--out", "x.gif"], "blx render writes MP4 video; give a path ending"),
    (["render", "anyrun", "--skills", "0,x"], "expected comma-separated skill numbers"),
    (["eval", "anyrun", "--key-seeds", "0,x"], "--key-seeds '0,x': give distinct ints in 0..2**31"),
    (["eval", "anyrun", "--key-seeds", "1,1"], "--key-seeds '1,1': give distinct ints"),
    (["eval", "anyrun", "--key-seeds", "-1"], "--key-seeds '-1': give distinct ints"),
    (["eval", "anyrun", "--metrics-only"], "--metrics-only applies with --key-seeds"),
    (["eval", "anyrun", "--eval-protocol", "quick"], "--eval-protocol applies with --key-seeds"),
    (["eval", "anyrun", "--key-seeds", "0", "--eval-protocol", "slow"],
     "--eval-protocol 'slow': give one of quick, final"),
    (["eval", "anyrun", "--eval-actions", "greedy"], "--eval-actions 'greedy': give one of "
                                                     "sampled, mean"),
])
def test_bad_input_is_one_line_and_exit_status_2(argv, message, capsys):
  assert cli.main(argv) == 2
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1 and message in err[0], err
  assert "Traceback" not in err[0]


def test_incompatible_or_existing_run_directories(trained, tmp_path, capsys):
  # An existing run is never overwritten without --resume.
  assert cli.main(["train", "--out", trained, *TINY]) == 2
  assert "already holds a run" in capsys.readouterr().err
  # A run directory from another format version.
  old = tmp_path / "old"
  old.mkdir()
  (old / "config.json").write_text(json.dumps({"format_version": 0}))
  assert cli.main(["eval", str(old)]) == 2
  assert "run format 0" in capsys.readouterr().err
  assert cli.main(["eval", str(tmp_path)]) == 2
  assert "not a blx run directory" in capsys.readouterr().err
  (old / "config.json").write_text("[1, 2]")   # valid JSON, not a run config
  assert cli.main(["eval", str(old)]) == 2
  assert "expected a JSON object (a blx run config), got a list" in capsys.readouterr().err
  # A damaged checkpoint is called damaged (not "another config"); the file is left as it was.
  damaged = tmp_path / "damaged"
  shutil.copytree(trained, damaged)
  npz = damaged / "checkpoint" / "checkpoint.npz"
  npz.write_bytes(npz.read_bytes()[:1000])
  assert cli.main(["eval", str(damaged)]) == 2
  err = capsys.readouterr().err
  assert "checkpoint.npz is damaged and cannot be read" in err and "another" not in err, err
  from blx.experiments import runs
  with pytest.raises(runs.RunError, match=r"checkpoint: .*checkpoint.npz is damaged"):
    runs.load_run(str(damaged))
  assert len(npz.read_bytes()) == 1000


def test_resume_reads_the_run_and_never_writes_on_a_contradiction(trained, tmp_path, capsys):
  config = os.path.join(trained, "config.json")
  before = open(config, "rb").read()
  # Flags that contradict the run are named; the run directory is not touched.
  assert cli.main(["train", "--resume", trained, "--objective", "gail"]) == 2
  assert ("--objective 'gail' contradicts the run, where it is 'diayn'"
          in capsys.readouterr().err)
  assert cli.main(["train", "--resume", trained, "--config", "num_envs=32"]) == 2
  assert "--config num_envs=32 contradicts the run, where it is 16" in capsys.readouterr().err
  assert open(config, "rb").read() == before
  # Nothing to resume, or no directory named.
  assert cli.main(["train", "--resume", str(tmp_path / "nope")]) == 2
  assert "no run directory at" in capsys.readouterr().err
  assert cli.main(["train", "--resume"]) == 2
  assert "name the run directory" in capsys.readouterr().err
  # A directory with a checkpoint but no config.json is not overwritten by a new run.
  orphan = tmp_path / "orphan"
  (orphan / "checkpoint").mkdir(parents=True)
  assert cli.main(["train", "--out", str(orphan), *TINY]) == 2
  assert "holds a checkpoint but no config.json" in capsys.readouterr().err
  # No flags: the run continues from its own config.json (here it had finished: it is evaluated
  # again) and config.json stays as it was; agreeing flags are accepted.
  assert cli.main(["train", "--resume", trained, "--seeds", "0,1"]) == 0
  assert open(config, "rb").read() == before
  assert os.path.exists(os.path.join(trained, "eval.json"))


def test_a_run_stopped_early_keeps_its_metrics_and_its_resume_continues_them(tmp_path):
  from blx.experiments import runs
  ppo = {**TINY_CONFIG, "num_timesteps": 1600}
  spec = runs.RunSpec(env="point", objective="diayn", objective_options={"num_skills": 3},
                      ppo=ppo, seeds=(0, 1), env_params={"episode_length": 20})
  out = str(tmp_path / "run")

  def killed(row):  # the process dies right after the first evaluation
    raise KeyboardInterrupt

  with pytest.raises(KeyboardInterrupt):
    runs.train_run(spec, out, progress=killed)
  path = os.path.join(out, "metrics.csv")
  first = list(csv.DictReader(open(path)))
  assert [r["seed"] for r in first] == ["0", "1"]  # the first evaluation, for both seeds
  assert "eval.json" not in os.listdir(out)

  seen = []
  runs.train_run(spec, out, resume=True, progress=seen.append)
  rows = list(csv.DictReader(open(path)))
  assert len(seen) == 1 and len(rows) == 4  # the resumed process ran the second chunk only
  assert rows[:2] == first  # the first chunk's rows, as the stopped process wrote them
  steps = [float(r["env_steps"]) for r in rows[::2]]
  assert steps[1] == 2 * steps[0]
  # "time" adds the resumed process's wall time (its compilation at least) to the stopped one's.
  assert float(rows[2]["time"]) > float(rows[0]["time"]) + float(rows[2]["compile_seconds"])
  # Each process names its machine and the env steps it took the run over.
  stopped, resumed = runs.read_provenance(out)
  assert (stopped.from_env_steps, stopped.to_env_steps) == (0.0, steps[0])
  assert (resumed.from_env_steps, resumed.to_env_steps) == (steps[0], steps[1])
  import jax
  assert resumed.device == jax.devices()[0].device_kind and resumed.platform == "cpu"
  assert resumed.versions["jax"] == jax.__version__ and resumed.versions["mujoco-mjx"]
  assert resumed.started >= stopped.started


def test_a_run_goes_on_and_is_evaluated_with_the_settings_it_trained_with_after_defaults_move(
    tmp_path, monkeypatch, capsys):
  from blx import training
  from blx.experiments import runs
  spec = runs.RunSpec(env="point", objective="diayn", objective_options={"num_skills": 3},
                      ppo={**TINY_CONFIG, "num_timesteps": 1600}, seeds=(0,),
                      env_params={"episode_length": 20})
  out = str(tmp_path / "run")

  def killed(row):  # the process dies right after the first evaluation
    raise KeyboardInterrupt

  # The run begins under blx's defaults before session 61, which took the mean action.
  row = training.ppo_defaults
  monkeypatch.setattr(training, "ppo_defaults",
                      lambda env=None, **kw: row(env, **kw).replace(eval_actions="mean"))
  with pytest.raises(KeyboardInterrupt):
    runs.train_run(spec, out, progress=killed)
  began = ("mean", 1e-3)
  # Its checkpoint records no eval_actions, as one written before PPOConfig had it (the legs rows'
  # from before session 57): such a run took the mean action (UNRECORDED_SETTINGS).
  from blx.training import checkpoint
  ckpt = os.path.join(out, "checkpoint")
  recorded = checkpoint.read_meta(ckpt)["config"]
  assert (recorded["eval_actions"], recorded["entropy_cost"]) == began
  del recorded["eval_actions"]
  checkpoint.rewrite(ckpt, meta_update={"config": recorded})
  # blx's defaults moved after the run began: two settings its config.json leaves to them (today's
  # eval_actions, and an entropy_cost moved for the test).
  assert (row("point").eval_actions, row("point").entropy_cost) == ("sampled", 1e-3)
  monkeypatch.setattr(training, "ppo_defaults",
                      lambda env=None, **kw: row(env, **kw).replace(entropy_cost=0.05))
  capsys.readouterr()
  run = runs.load_run(out)  # as blx eval and the plots rebuild it
  assert (run.config.eval_actions, run.config.entropy_cost) == began
  err = capsys.readouterr().err
  assert "keeps the settings it trained with" in err
  assert "eval_actions 'mean' (blx's default now 'sampled')" in err
  assert "entropy_cost 0.001 (blx's default now 0.05)" in err
  # Its resume goes on as it trained (train refuses a checkpoint written with another config).
  done = runs.train_run(spec, out, resume=True, progress=None)
  assert (done.config.eval_actions, done.config.entropy_cost) == began
  assert os.path.exists(os.path.join(out, "eval.json"))
  # Each process recorded every setting it trained with, so that a report reading the run's
  # files (config.json names neither setting) names them beside the moved row.
  segments = runs.read_provenance(out)
  assert [s.ppo for s in segments] == [json.loads(json.dumps(dataclasses.asdict(done.config)))] * 2
  trained = runs.settings_as_trained(runs.read_spec(out).ppo, segments)
  monkeypatch.setattr(training.config, "ppo_defaults", training.ppo_defaults)
  named = training.config.off_row("point", trained)  # TINY_CONFIG's own settings too
  assert (named["eval_actions"], named["entropy_cost"]) == (("mean", "sampled"), (1e-3, 0.05))
  # A setting the run sets itself is its own: one that contradicts the checkpoint is refused.
  other = dataclasses.replace(spec, ppo={**spec.ppo, "entropy_cost": 0.05})
  with pytest.raises(ValueError, match="different config"):
    runs.train_run(other, out, resume=True, progress=None)


def test_the_eval_protocol_sets_the_rollouts_logged_during_training_and_a_run_keeps_it(
    trained, tmp_path, monkeypatch, capsys):
  import jax

  from blx.experiments import runs
  # The protocols' rollouts: DIAYN's quick evaluator runs 4 episodes for each of the 3 skills and
  # of 4 goals (LGR's), eval.json's 10 for each skill and of 10 goals.
  run = runs.load_run(trained)
  one_seed = jax.tree.map(lambda x: x[0], run.params)
  for quick, n in ((True, 4), (False, 10)):
    evaluator = runs.evaluator_for(run.env, run.objective, quick=quick)
    batch, _ = evaluator.episodes(run.policy, one_seed, jax.random.PRNGKey(0))
    assert jax.tree.leaves(batch.state)[0].shape[0] == (3 + n) * n
  # train_run logs the metrics with the protocol asked, and records it in provenance.json.
  asked = []
  real = runs.evaluator_for
  monkeypatch.setattr(runs, "evaluator_for",
                      lambda *a, quick=False: asked.append(quick) or real(*a, quick=quick))
  spec = runs.RunSpec(env="point", objective="diayn", objective_options={"num_skills": 3},
                      ppo={**TINY_CONFIG, "num_timesteps": 1600}, seeds=(0,),
                      env_params={"episode_length": 20})
  out = str(tmp_path / "final")

  def killed(row):  # stopped after the first evaluation, which logged MI
    assert "eval/mi" in row
    raise KeyboardInterrupt

  with pytest.raises(KeyboardInterrupt):
    runs.train_run(spec, out, progress=killed, eval_metrics=True, eval_protocol="final")
  assert asked == [False]
  assert [s.eval_protocol for s in runs.read_provenance(out)] == ["final"]
  # Resumed with the other protocol, it is refused before anything runs: one curve, one estimator.
  with pytest.raises(runs.RunError, match="with the 'final' protocol.*--eval-protocol final"):
    runs.train_run(spec, out, resume=True, eval_metrics=True, eval_protocol="quick")
  assert len(runs.read_provenance(out)) == 1 and asked == [False]
  # Resumed without a protocol, it keeps its own; a new run without one logs the quick protocol.
  with pytest.raises(KeyboardInterrupt):
    runs.train_run(spec, out, resume=True, progress=killed, eval_metrics=True)
  assert asked == [False, False]
  assert [s.eval_protocol for s in runs.read_provenance(out)] == ["final", "final"]
  with pytest.raises(KeyboardInterrupt):
    runs.train_run(spec, str(tmp_path / "quick"), progress=killed, eval_metrics=True)
  assert asked == [False, False, True]
  assert [s.eval_protocol for s in runs.read_provenance(str(tmp_path / "quick"))] == ["quick"]
  # An unknown protocol, or one with no metrics to log, is named before a directory is made.
  for protocol, metrics, message in (("slow", True, "'slow': valid are quick, final"),
                                     ("final", False, "none are logged: add --eval-metrics")):
    with pytest.raises(runs.RunError, match=message):
      runs.train_run(spec, str(tmp_path / "new"), eval_metrics=metrics, eval_protocol=protocol)
    assert not os.path.exists(tmp_path / "new")
  assert cli.main(["train", "--out", str(tmp_path / "cli"), "--eval-protocol", "final",
                   *TINY]) == 2
  assert "none are logged: add --eval-metrics" in capsys.readouterr().err
  with pytest.raises(SystemExit) as e:
    cli.main(["train", "--eval-protocol", "slow", *TINY])
  err = capsys.readouterr().err
  assert e.value.code == 2 and "invalid choice: 'slow'" in err
  assert all(f"'{p}'" in err for p in runs.EVAL_PROTOCOLS)  # the flag offers runs' protocols
  # a sweep refuses it before its directory is made
  path = tmp_path / "spec.json"
  path.write_text(json.dumps({"env": "point", "objective": "diayn", "steps": 1600,
                              "config": dict(TINY_CONFIG, policy_hidden=[[16, 16]],
                                             value_hidden=[[16, 16]])}))
  assert cli.main(["sweep", str(path), "--out", str(tmp_path / "sweep"), "--eval-protocol",
                   "final"]) == 2
  assert "none are logged: add --eval-metrics" in capsys.readouterr().err
  assert not os.path.exists(tmp_path / "sweep")


def test_provenance_is_empty_for_an_older_run_and_a_foreign_file_is_named(tmp_path):
  from blx.experiments import runs
  assert runs.read_provenance(str(tmp_path)) == []  # a run trained before blx recorded it
  # a segment written before blx recorded its LGR goals (session 41) reads as None: those runs
  # drew the partitionable goals
  old = {k: v for k, v in dataclasses.asdict(runs.this_machine()).items() if k != "lgr_goals"}
  (tmp_path / "provenance.json").write_text(json.dumps({"segments": [old]}))
  (segment,) = runs.read_provenance(str(tmp_path))
  assert segment.lgr_goals is None and segment.device == old["device"]
  for foreign in (json.dumps({"segments": [{"device": "cpu"}]}), "[1, 2]", '{"segments": [1]}',
                  "{not json"):
    (tmp_path / "provenance.json").write_text(foreign)
    with pytest.raises(runs.RunError, match="provenance.json: not a provenance file of blx.*"
                                            "move it aside"):
      runs.read_provenance(str(tmp_path))


def test_envs_describes_an_env(capsys):
  assert cli.main(["envs", "ant"]) == 0
  out = capsys.readouterr().out
  assert "action size 8" in out and "vel_xy" in out and "[13, 14]" in out


def test_plot_axes_name_the_quantity_and_the_observation_index():
  from blx.experiments.plots import feature_labels
  from tests.conftest import make_env
  assert feature_labels(make_env("point"), (0, 3)) == ["agent1 position x (obs 0)",
                                                        "agent1 velocity y (obs 3)"]
  # The ant's joints in its MJCF order: hip_1, ankle_1, hip_2, ... (angles at 5-12, velocities at
  # 19-26); the quaternion has no per-axis name.
  assert feature_labels(make_env("ant"), (13, 14, 7, 21, 1)) == [
      "agent1 velocity x (obs 13)", "agent1 velocity y (obs 14)", "agent1/hip_2 (obs 7)",
      "agent1/hip_2 velocity (obs 21)", "agent1/root_quat[0] (obs 1)"]


@pytest.mark.parametrize("content, suffix, message", [
    ("{not json", ".json", "cannot be read: JSONDecodeError"),
    ("env: [point\n", ".yaml", "cannot be read: "),
    ("SPEC = {", ".py", "cannot be read: SyntaxError"),
    ('{"env": "point", "objective": "gcrl", "seeds": 3}', ".json",
     "seeds must be a list of distinct ints in 0..2**31 - 1"),
    ('{"env": "point", "objective": "gcrl", "seeds": [0, 0]}', ".json", "distinct"),
    ('{"env": "point", "objective": "gcrl", "config": 5}', ".json",
     "config must be a mapping of setting -> value"),
    ('{"env": "point", "objective": "gcrl", "name": "../../escape"}', ".json",
     "must be a plain directory name"),
])
def test_bad_sweep_specs_are_one_line(tmp_path, capsys, content, suffix, message):
  path = tmp_path / f"spec{suffix}"
  path.write_text(content)
  assert cli.main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
  err = capsys.readouterr().err.strip().splitlines()
  assert len(err) == 1 and message in err[0] and "Traceback" not in err[0], err
  assert not os.path.exists(tmp_path / "out")


def test_unwritable_output_is_one_line(tmp_path, capsys):
  blocker = tmp_path / "file"
  blocker.write_text("")
  assert cli.main(["train", "--out", str(blocker / "run"), *TINY]) == 2
  err = capsys.readouterr().err
  assert "Traceback" not in err
  last = err.strip().splitlines()[-1]
  assert last.startswith("blx train: error: Not a directory") and str(blocker) in last, err


@pytest.mark.parametrize("text, value", [
    ("true", True), ("False", False), ("TRUE", True), ("True", True), ("null", None),
    ("None", None), ("1e-3", 1e-3), ("16384", 16384), ("[13,14]", [13, 14]), ("vel_xy", "vel_xy"),
])
def test_config_values_take_python_and_json_spellings(text, value):
  parsed = cli._parse_pairs([f"staggered_starts={text}"], "--config")["staggered_starts"]
  assert parsed == value and type(parsed) is type(value)


def test_train_help_lists_envs_objectives_and_config_defaults(capsys):
  with pytest.raises(SystemExit) as info:
    cli.main(["train", "--help"])
  assert info.value.code == 0
  out = capsys.readouterr().out
  from blx import envs, objectives
  assert all(name in out for name in envs.list_envs())
  assert all(f"  {name}: " in out for name in objectives.list_objectives())
  assert "num_envs=2048" in out and "entropy_cost=0.01" in out
  assert "default 8, as the API" in out  # one DIAYN skill count for the CLI, the API and sweeps
  spec = cli._spec_from_args(cli._parser().parse_args(["train"]))
  assert "num_skills" not in spec.objective_options


def test_a_multi_agent_scene_trains_evaluates_and_renders_every_agent(tmp_path, capsys):
  out = str(tmp_path / "chase")
  args = ["train", "--env", "chase", "--objective", "task", "--env-param", "main_agent='point'",
          "--env-param", "other_agent='point'", "--out", out, *TINY]
  assert cli.main(args) == 0
  rows = list(csv.DictReader(open(os.path.join(out, "metrics.csv"))))
  for agent in ("agent0", "agent1"):
    for key in ("train/reward", "eval/episode_reward", "eval/episode_score"):
      assert np.isfinite(float(rows[-1][f"{key}/{agent}"])), (key, agent)
  # The total is the sum of the agents'.
  np.testing.assert_allclose(float(rows[-1]["eval/episode_reward"]),
                             sum(float(rows[-1][f"eval/episode_reward/agent{i}"]) for i in (0, 1)),
                             rtol=1e-5)
  capsys.readouterr()
  assert cli.main(["eval", out, "--json"]) == 0
  per_seed = json.loads(capsys.readouterr().out)["per_seed"]
  assert {"eval/episode_reward/agent0", "eval/episode_score/agent1"} <= set(per_seed)
  assert cli.main(["envs", "chase"]) == 0
  assert ("agent1: actions [8, 9, 10, 11, 12, 13, 14, 15], rewards agent1/run, "
          "agent0__agent1/chase") in capsys.readouterr().out  # the default scene: two ants
  video = str(tmp_path / "chase.mp4")
  proc = subprocess.run([sys.executable, "-m", "blx.experiments.cli", "render", out, "--width",
                         "96", "--height", "64", "--out", video], capture_output=True, text=True,
                        env={**os.environ, "PYTHONPATH": ROOT}, timeout=600)
  if "rendering needs an OpenGL backend" in proc.stderr:
    pytest.skip("no headless OpenGL on this machine (install libegl1 or libosmesa6)")
  assert proc.returncode == 0, proc.stderr[-2000:]


def test_agent_pays_a_reward_free_objective_to_one_agent_of_a_scene(tmp_path, capsys):
  out = str(tmp_path / "chase_diayn")
  scene = ["--env", "chase", "--env-param", "main_agent='point'", "--env-param",
           "other_agent='point'"]
  assert cli.main(["train", *scene, "--objective", "diayn", "--num-skills", "2", "--agent",
                   "agent1", "--out", out, *TINY]) == 0
  config = json.load(open(os.path.join(out, "config.json")))
  assert config["agent"] == "agent1"
  from blx.experiments import runs
  run = runs.load_run(out)
  assert run.spec.agent == "agent1" and run.objective.name == "diayn@agent1"
  # The objective reads the agent's own velocity, not the main component's.
  assert run.objective.spec.obs_indices == run.env.obs_indices("agent1/vel_xy")
  assert run.objective.spec.obs_indices != run.env.obs_indices("vel_xy")
  capsys.readouterr()
  assert cli.main(["eval", out, "--json"]) == 0
  assert "eval/mi" in json.loads(capsys.readouterr().out)["per_seed"]
  assert cli.main(["train", "--resume", out, "--agent", "agent0"]) == 2
  assert "--agent 'agent0' contradicts the run, where it is 'agent1'" in capsys.readouterr().err


@pytest.mark.parametrize("args, named", [
    (["--env", "point", "--agent", "agent1"], "single-agent env"),
    (["--env", "chase", "--env-param", "main_agent='point'", "--env-param", "other_agent='point'",
      "--agent", "agent7"], r"has agents \['agent0', 'agent1'\]"),
    (["--env", "chase", "--env-param", "main_agent='point'", "--env-param", "other_agent='point'",
      "--objective", "task", "--agent", "agent0"], "already gets its own env reward"),
])
def test_bad_agent_is_named_before_a_run_directory_is_made(tmp_path, capsys, args, named):
  out = tmp_path / "run"
  assert cli.main(["train", *args, "--out", str(out), *TINY]) == 2
  assert re.search(named, capsys.readouterr().err)
  assert not out.exists()


def test_a_bad_time_limit_is_named_before_a_run_directory_is_made(tmp_path, capsys, monkeypatch):
  out = tmp_path / "run"
  monkeypatch.setenv("BLX_STOP_BY", "soon")
  assert cli.main(["train", "--out", str(out), *TINY]) == 2
  err = capsys.readouterr().err
  assert "$BLX_STOP_BY='soon': give the time limit as a Unix time" in err
  assert not out.exists() and "[blx] training" not in err   # nor is a run announced


def test_bad_checkpoint_segments_are_named_before_a_run_directory_is_made_or_a_resume_recorded(
    trained, tmp_path, capsys, monkeypatch):
  # TINY: 10 iterations of 160 env steps in 2 chunks, so 1 to 5 segments a chunk
  out = tmp_path / "run"
  for setting, named in [("6", "$BLX_CHECKPOINT_SEGMENTS=6"),
                         ("half", "$BLX_CHECKPOINT_SEGMENTS='half'")]:
    monkeypatch.setenv("BLX_CHECKPOINT_SEGMENTS", setting)
    assert cli.main(["train", "--out", str(out), *TINY]) == 2
    err = capsys.readouterr().err
    assert (f"{named}: give a whole number of segments per chunk, 1 to 5 (this run's iterations "
            "per chunk)") in err
    assert not out.exists() and "[blx] training" not in err   # nor is a run announced
  # a resume records nothing (provenance.json would name a machine that trained nothing)
  resumed = str(tmp_path / "resumed")
  shutil.copytree(trained, resumed)
  before = {name: open(os.path.join(resumed, name), "rb").read()
            for name in ("config.json", "provenance.json", "metrics.csv")}
  assert cli.main(["train", "--resume", resumed]) == 2
  err = capsys.readouterr().err
  assert "$BLX_CHECKPOINT_SEGMENTS='half'" in err and "[blx] training" not in err
  assert {name: open(os.path.join(resumed, name), "rb").read() for name in before} == before


@pytest.mark.parametrize("setting, value, named", [
    ("BLX_CHECKPOINT_SEGMENTS", "6", "$BLX_CHECKPOINT_SEGMENTS=6: give a whole number of segments "
     "per chunk, 1 to 5"),
    ("BLX_STOP_BY", "soon", "$BLX_STOP_BY='soon': give the time limit as a Unix time"),
])
def test_a_sweep_refuses_a_bad_time_setting_before_it_makes_its_folder(
    tmp_path, capsys, monkeypatch, setting, value, named):
  # the points' TINY settings: 10 iterations in 2 chunks, so 1 to 5 segments a chunk
  spec = {"env": "point", "objective": ["gcrl", "gail"], "steps": 1600,
          "config": dict(TINY_CONFIG, policy_hidden=[[16, 16]], value_hidden=[[16, 16]]),
          "env_params": {"episode_length": 20}}
  path = tmp_path / "spec.json"
  path.write_text(json.dumps(spec))
  out = tmp_path / "sweep"
  monkeypatch.setenv(setting, value)
  assert cli.main(["sweep", str(path), "--out", str(out)]) == 2
  assert named in capsys.readouterr().err
  assert not out.exists()   # a rerun would have taken an empty folder for its own


def test_a_sweep_spec_can_name_the_agent_or_sweep_over_agents():
  from blx.experiments import sweep
  spec = {"env": "chase", "objective": "diayn", "agent": ["agent0", "agent1"],
          "env_params": {"main_agent": "point", "other_agent": "point"}}
  points = sweep.expand(spec)
  assert [(name, s.agent) for name, s in points] == [("agent=agent0", "agent0"),
                                                      ("agent=agent1", "agent1")]
  (name, one), = sweep.expand(dict(spec, agent="agent1"))
  assert one.agent == "agent1"


def test_a_sweep_point_run_for_another_agent_is_not_reused(tmp_path):
  import dataclasses
  from blx.experiments import runs, sweep
  from tests.conftest import make_env
  spec = runs.RunSpec(env="chase", objective="diayn", objective_options={}, ppo={},
                      env_params={"main_agent": "point", "other_agent": "point"}, agent="agent0")
  env = make_env("chase", main_agent="point", other_agent="point")
  runs.write_config(str(tmp_path), spec, env)
  sweep._check_same_point("p", str(tmp_path), spec, env.desc)  # the same point: reused
  with pytest.raises(runs.RunError, match="agent: 'agent0' -> 'agent1'"):
    sweep._check_same_point("p", str(tmp_path), dataclasses.replace(spec, agent="agent1"), env.desc)


def test_a_humanoid_run_configured_before_its_env_observed_brax_parts_is_rebuilt_as_it_trained(
    tmp_path):
  # Until 2026-12-06 the registered humanoid observed the state's 45 numbers; its desc named no
  # observers. Such a run must rebuild the env it trained with (its checkpoint's input size), and
  # a sweep must not take it for a point of the humanoid as blx builds it now.
  from types import SimpleNamespace
  from blx import envs
  from blx.experiments import runs, sweep
  spec = runs.RunSpec(env="humanoid", objective="diayn", objective_options={}, ppo={})
  now = runs.build(spec)[0]
  older = envs.get_desc("humanoid")
  del older["components"]["agent1"]["observers"]
  runs.write_config(str(tmp_path), spec, SimpleNamespace(desc=older))
  rebuilt = runs.build(runs.read_spec(str(tmp_path)))[0]
  assert (rebuilt.observation_size, now.observation_size) == (45, 45 + 12 + 17)
  with pytest.raises(runs.RunError, match="the env's desc differs"):
    sweep._check_same_point("p", str(tmp_path), spec, now.desc)
