"""PPO end to end on the point mass: learning, seeds under vmap, no recompiles, guard, resume,
data parallelism, and the objective hook."""

from __future__ import annotations

import functools
import os
import re
import shutil
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from blx import envs, training
from blx.objectives import task
from blx.training import checkpoint
from tests.training.tiny import SMALL, reach_latent

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@functools.lru_cache(maxsize=None)
def point_goal():
  return envs.create("point_goal")


def test_ppo_learns_to_reach_a_goal():
  config = training.ppo_defaults("point", num_timesteps=80_000)
  result = training.train(point_goal(), task(), config, seeds=(0,), progress=False)
  trainer = training.make_trainer(point_goal(), task(), config)
  untrained = jax.jit(trainer.evaluate)(
      training.policy_params(jax.jit(trainer.init)(jax.random.PRNGKey(0))), jax.random.PRNGKey(1))
  # The untrained policy stays near the origin, 3 m from the goal for 50 steps: reward about -150.
  # A trained one gets there in about 15 steps at its top speed of 2 m/s: about -35 to -50.
  before = float(untrained["eval/episode_reward"])
  after = result.metrics[-1]["eval/episode_reward"][0]
  assert before < -140
  assert after > -75, (before, after)


def test_vmap_over_seeds_equals_separate_runs():
  train = training.make_train(envs.create("point", episode_length=20), reach_latent(), SMALL)
  keys = jax.random.split(jax.random.PRNGKey(0), 3)
  batched_state, batched_metrics = jax.jit(jax.vmap(train))(keys)
  single = jax.jit(train)
  for i in range(3):
    state, metrics = single(keys[i])
    for a, b in zip(jax.tree.leaves(state.params), jax.tree.leaves(batched_state.params)):
      np.testing.assert_allclose(a, b[i], rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(metrics["eval/episode_reward"],
                               batched_metrics["eval/episode_reward"][i], rtol=1e-4, atol=1e-4)


def test_second_call_of_the_train_step_does_not_recompile():
  trainer = training.make_trainer(envs.create("point", episode_length=20), reach_latent(), SMALL)
  state = jax.jit(trainer.init)(jax.random.PRNGKey(0))
  chunk = jax.jit(trainer.chunk)
  state, _ = chunk(state)
  state, _ = chunk(state)
  assert chunk._cache_size() == 1


def test_an_iteration_is_update_after_collect():
  # The halves a profiler times apart compose to exactly the training step.
  trainer = training.make_trainer(envs.create("point", episode_length=20), reach_latent(), SMALL)
  state = jax.jit(trainer.init)(jax.random.PRNGKey(0))
  chunked, _ = jax.jit(trainer.chunk)(state)
  collect, update = jax.jit(trainer.collect), jax.jit(trainer.update)
  manual = state
  for _ in range(trainer.iterations_per_chunk):
    manual, data = collect(manual)
    assert data.obs.shape[:2] == (SMALL.num_unrolls * SMALL.num_envs, SMALL.unroll_length)
    manual, _ = update(manual, data)
  assert int(manual.iteration) == int(chunked.iteration) == trainer.iterations_per_chunk
  for a, b in zip(jax.tree.leaves(manual.params), jax.tree.leaves(chunked.params)):
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-5)


def test_objective_hook_replaces_the_reward_and_trains_its_params():
  # `point` has no task reward: anything learned comes from the objective's reward.
  config = training.ppo_defaults("point", num_timesteps=60_000)
  result = training.train(envs.create("point"), reach_latent(), config, progress=False)
  final = result.metrics[-1]
  first = result.metrics[0]
  # z = (2, -1) is 2.24 m away: staying put scores about -112 over 50 steps.
  assert final["eval/episode_reward"][0] > -70, final["eval/episode_reward"]
  assert final["eval/episode_reward"][0] > first["eval/episode_reward"][0]
  # The objective's loss (w - 1)^2 was minimised by the same Adam: w moved from 0 toward 1.
  w = float(result.params.objective["w"][0])
  assert 0.5 < w < 1.5
  assert "loss/tiny" in final and "tiny/mean_obs" in final


def test_non_finite_loss_stops_training_and_keeps_the_last_checkpoint(tmp_path):
  directory = str(tmp_path / "ckpt")
  checkpoint.save(directory, {"x": np.ones(3)}, {"chunk": 1})  # an earlier good checkpoint
  before = open(checkpoint.path(directory), "rb").read()
  # The loss's NaN is in its objective term (the gradient of w stays finite), from the update's
  # first SGD step on, where the policy has not been stepped yet: its ratio is far from overflow
  # (not 1 exactly: the normaliser takes in the batch before the step, as in Brax).
  with pytest.raises(training.NonFiniteError,
                     match=r"non-finite loss \(its objective term at the first non-finite SGD step, "
                           r"where the largest log-ratio of pi to pi_old was ([-0-9.e]+)\) at "
                           r"iteration 0 \(seed 0\); the last good checkpoint in .* is kept") as e:
    env = envs.create("point", episode_length=20)
    training.train(env, reach_latent(poison=True), SMALL, progress=False,
                   checkpoint_dir=directory)
  log_ratio = float(re.search(r"was ([-0-9.e]+)\)", str(e.value)).group(1))
  assert 0 < log_ratio < 10, log_ratio
  assert open(checkpoint.path(directory), "rb").read() == before


_TWO_DEVICES = {"XLA_FLAGS": f"{os.environ.get('XLA_FLAGS', '')} "
                "--xla_force_host_platform_device_count=2"}


def _run(*args, env=None):
  env = {**os.environ, "PYTHONPATH": ROOT, **(env or {})}
  return subprocess.run([sys.executable, "-m", "tests.training._run", *args], cwd=ROOT, env=env,
                        capture_output=True, text=True, timeout=600)


def _leaves(path):
  with np.load(path) as f:
    return [f[k] for k in sorted(f.files, key=lambda k: (len(k), k)) if k.startswith("arr_")]


def test_resume_after_interrupt_in_a_fresh_process_gives_identical_params(tmp_path):
  full = _run("full", str(tmp_path / "full.npz"))
  assert full.returncode == 0, full.stderr[-3000:]
  ckpt = str(tmp_path / "ckpt")
  interrupted = _run("interrupt", str(tmp_path / "none.npz"), ckpt)
  assert interrupted.returncode == 130, interrupted.stderr[-3000:]
  assert "resume=True" in interrupted.stderr
  assert checkpoint.read_meta(ckpt)["chunk"] == 1
  shutil.copytree(ckpt, tmp_path / "ckpt_two")
  resumed = _run("resume", str(tmp_path / "resumed.npz"), ckpt)
  assert resumed.returncode == 0, resumed.stderr[-3000:]
  for a, b in zip(_leaves(tmp_path / "full.npz"), _leaves(tmp_path / "resumed.npz")):
    np.testing.assert_array_equal(a, b)
  # The same checkpoint, written on one device, resumed on two: the restored state (on one
  # device) is laid out as the chunk keeps it, which the compiled programs used to refuse after
  # the first chunk; it ends as the one-device run does, up to the order of reductions, and with
  # no leaf laid out otherwise, so nothing moves between chunks.
  two = _run("resume", str(tmp_path / "two.npz"), str(tmp_path / "ckpt_two"), env=_TWO_DEVICES)
  assert two.returncode == 0, two.stderr[-3000:]
  with np.load(tmp_path / "two.npz") as f:
    assert (int(f["devices"]), int(f["moved"])) == (2, 0)
  for a, b in zip(_leaves(tmp_path / "resumed.npz"), _leaves(tmp_path / "two.npz")):
    np.testing.assert_allclose(a, b, rtol=1e-3, atol=1e-4)


def test_an_interrupt_does_not_wait_for_the_chunk_in_flight(tmp_path):
  # The second chunk's evaluation is held up on the device for 120 s when Ctrl-C comes after the
  # first: the process ends at once, keeping the first chunk's checkpoint, where it used to wait
  # for the chunk in flight (its dispatch thread held the interpreter's exit).
  ckpt = str(tmp_path / "ckpt")
  interrupted = _run("in-flight", str(tmp_path / "none.npz"), ckpt, env={"BLX_TEST_SLEEP": "120"})
  ended = time.time()
  assert interrupted.returncode == 130, interrupted.stderr[-3000:]
  at = float(re.search(r"interrupted at ([0-9.]+)", interrupted.stdout).group(1))
  assert ended - at < 60, f"the process ended {ended - at:.0f} s after Ctrl-C"
  assert checkpoint.read_meta(ckpt)["chunk"] == 1


def test_two_devices_match_one_device(tmp_path):
  # The env axis is sharded over the devices; the global batch, its permutation and the gradient
  # are the same arithmetic, so only the order of floating-point reductions differs.
  one = _run("dp", str(tmp_path / "one.npz"))
  two = _run("dp", str(tmp_path / "two.npz"), env=_TWO_DEVICES)
  assert one.returncode == 0, one.stderr[-3000:]
  assert two.returncode == 0, two.stderr[-3000:]
  assert int(np.load(tmp_path / "two.npz")["devices"]) == 2
  for a, b in zip(_leaves(tmp_path / "one.npz"), _leaves(tmp_path / "two.npz")):
    np.testing.assert_allclose(a, b, rtol=1e-3, atol=1e-4)


def test_non_finite_report_names_the_first_bad_iteration_and_everything_bad_there():
  from blx.training.loop import _check_finite
  shape = (2, 4)  # [seeds, iterations]
  flags = {q: np.zeros(shape, bool) for q in ("observation", "loss", "params")}
  flags["loss"][0, 2] = flags["loss"][1, 3] = True
  flags["observation"][1, 2] = flags["params"][1, 2] = True
  metrics = {f"nonfinite/{q}": f for q, f in flags.items()}
  # Iteration 2 comes first; there seed 0 has a bad loss only (seed order breaks the tie).
  with pytest.raises(training.NonFiniteError, match=r"non-finite loss at iteration 12 \(seed 7\)$"):
    _check_finite(metrics, 10, [7, 8], None)
  flags["loss"][0, 2] = False
  # Now seed 8's iteration 2 is first: observation, loss and params, observation named first.
  flags["loss"][1, 2] = True
  with pytest.raises(training.NonFiniteError,
                     match=r"non-finite observation and loss and params at iteration 12 \(seed 8\); "
                           r"no checkpoint had been written to ckpt yet"):
    _check_finite(metrics, 10, [7, 8], "ckpt")   # "ckpt" holds no checkpoint
  flags["loss"][1, 2] = flags["observation"][1, 2] = flags["params"][1, 2] = flags["loss"][1, 3] = False
  _check_finite(metrics, 10, [7, 8], None)  # all finite: no error


def test_non_finite_report_names_the_reward_and_the_loss_terms_with_the_log_ratio():
  from blx.training.loop import _check_finite
  shape = (1, 3)  # [seeds, iterations]
  names = ("observation", "reward", "loss", "grads", "params", "loss/policy", "loss/value",
           "loss/entropy", "loss/objective")
  flags = {q: np.zeros(shape, bool) for q in names}
  metrics = {f"nonfinite/{q}": f for q, f in flags.items()}
  metrics["nonfinite/log_ratio_max"] = np.array([[0.0, 91.25, 0.0]])
  flags["reward"][0, 2] = True
  with pytest.raises(training.NonFiniteError, match=r"^non-finite reward at iteration 2 \(seed 0\)$"):
    _check_finite(metrics, 0, [0], None)
  # Iteration 1 comes first: PPO's ratio overflowed (log-ratio above 88.7) in its policy term,
  # and the gradient and the parameters followed.
  for q in ("loss", "loss/policy", "loss/value", "grads", "params"):
    flags[q][0, 1] = True
  with pytest.raises(training.NonFiniteError,
                     match=r"^non-finite loss \(its policy and value terms at the first non-finite "
                           r"SGD step, where the largest log-ratio of pi to pi_old was 91.25\) and "
                           r"grads and params at iteration 1 \(seed 0\)$"):
    _check_finite(metrics, 0, [0], None)


def test_ppo_loss_bootstraps_from_the_true_next_states():
  """``ppo_loss`` against GAE computed from V at every true next state s'_t (the sequence has an
  auto-reset after a termination and one after a truncation, where s_{t+1} is not s'_t)."""
  import dataclasses

  from blx.training import losses, networks, ppo
  config = dataclasses.replace(SMALL, entropy_cost=0.0, reward_scaling=2.0, discounting=0.9,
                               gae_lambda=0.8, normalize_advantage=False)
  learner = ppo.make_learner(3, 2, task(), config)
  keys = jax.random.split(jax.random.PRNGKey(0), 8)
  params = ppo.Params(policy=learner.policy_net.init(keys[0], jnp.zeros(3)),
                      value=learner.value_net.init(keys[1], jnp.zeros(3)), objective=None)
  stats = networks.init_stats(3)
  T = 5
  states = jax.random.normal(keys[2], (1, T + 1, 3))
  obs, next_obs = states[:, :-1], states[:, 1:]
  # Step 1 terminates and step 3 is truncated: the next entries (2, 4) are fresh episodes, and the
  # true next states s'_1, s'_3 are other states.
  true_next = jax.random.normal(keys[3], (1, T, 3))
  next_obs = next_obs.at[:, 1].set(true_next[:, 1]).at[:, 3].set(true_next[:, 3])
  done = jnp.zeros((1, T)).at[:, 1].set(1.0).at[:, 3].set(1.0)
  truncation = jnp.zeros((1, T)).at[:, 3].set(1.0)
  reward = jax.random.normal(keys[4], (1, T))
  logits = learner.policy_net.apply(params.policy, learner.policy_input(stats, obs, None))
  raw = networks.sample_raw_action(logits, keys[5])
  batch = ppo.Rollout(obs=obs, raw_action=raw, action=jnp.tanh(raw),
                      log_prob=networks.log_prob_raw(logits, raw), next_obs=next_obs, reward=reward,
                      env_reward=reward, done=done, truncation=truncation, z=jnp.zeros((1, T, 0)))
  total, metrics = ppo.ppo_loss(learner, params, batch, stats, keys[6])

  value = lambda x: learner.value_net.apply(params.value,
                                            learner.policy_input(stats, x, None))[..., 0]
  # Where s'_t is known (every step but the truncation inside the sequence) delta uses V(s'_t).
  advantage, _ = losses.gae(2.0 * reward[0], value(obs[0]), value(next_obs[0]),
                            done[0] * (1 - truncation[0]), done[0], discount=0.9, lam=0.8,
                            known_t=1.0 - truncation[0])
  # The policy is the one that acted (ratio 1): surrogate = -mean(A); value targets A + V.
  np.testing.assert_allclose(metrics["loss/policy"], -advantage.mean(), rtol=1e-5, atol=1e-6)
  np.testing.assert_allclose(metrics["loss/value"], 0.25 * jnp.mean(advantage**2), rtol=1e-5)
  np.testing.assert_allclose(total, metrics["loss/policy"] + metrics["loss/value"], rtol=1e-5)
  assert advantage[3] == 0.0 and advantage[1] != 0.0   # the truncation inside teaches nothing


@pytest.mark.parametrize("field, value, message", [
    ("learning_rate", float("nan"), "learning_rate must be finite, got nan"),
    ("clipping_epsilon", float("inf"), "clipping_epsilon must be finite, got inf"),
    ("reward_scaling", 0.0, "reward_scaling > 0"),
    ("entropy_cost", -0.1, "entropy_cost must be >= 0"),
    ("max_grad_norm", float("inf"), "max_grad_norm must be None or a positive number"),
])
def test_ppo_config_rejects_non_finite_and_out_of_range_numbers(field, value, message):
  import dataclasses
  with pytest.raises(ValueError, match=message):
    dataclasses.replace(SMALL, **{field: value})


def test_the_trainer_runs_the_env_as_given_with_its_episode_and_action_repeat():
  # The env owns its episode: an evaluation episode is the env's 8 steps (4 policy steps at action
  # repeat 2), and an iteration counts the repeats among its env steps.
  base = envs.unwrap(point_goal())
  config = SMALL.replace(num_eval_envs=2)
  for length, repeat in ((8, 1), (8, 2), (5, 2)):
    env = envs.episode(envs.action_repeat(base, repeat), length)
    trainer = training.make_trainer(env, task(), config)
    out = jax.jit(trainer.evaluate)(
        training.policy_params(jax.jit(trainer.init)(jax.random.PRNGKey(0))), jax.random.PRNGKey(1))
    # The point never terminates, so every episode lasts the whole time limit (5 env steps at
    # repeat 2 take 3 policy steps, i.e. 6 env steps).
    assert float(out["eval/episode_length"]) == repeat * -(-length // repeat), (length, repeat)
    assert trainer.env_steps_per_iteration == config.env_steps_per_iteration * repeat
  assert envs.create("point").episode_length == 50  # the point's registered episode
  assert envs.registry.episode_length("ant") == 1000  # Braxlines' for the bodies


def test_the_evaluation_takes_the_mean_action_or_samples_as_the_original():
  # point_goal resets without noise and the task has no latent: with the mean action (an option,
  # blx's default before session 61) the evaluation's episodes are one episode repeated; sampled
  # actions (blx's default, Braxlines' PPO's evaluation) give as many episodes as envs, the same
  # ones again for the same key.
  env = envs.episode(envs.unwrap(point_goal()), 8)
  params = None
  totals = {}
  for actions, key in (("mean", 1), ("sampled", 1), ("sampled", 1), ("sampled", 2)):
    trainer = training.make_trainer(env, task(), SMALL.replace(num_eval_envs=4,
                                                               eval_actions=actions))
    if params is None:
      params = training.policy_params(jax.jit(trainer.init)(jax.random.PRNGKey(0)))

    @jax.jit
    def episodes(params, key):
      batch, score = trainer.evaluation_episodes(params, key)
      records = envs.rollout_together([batch])[0]
      return records[0]["eval/episode_env_reward"].sum(0), score(records)

    per_env, score = episodes(params, jax.random.PRNGKey(key))
    # the reported total is the mean of the episodes' totals
    np.testing.assert_allclose(score["eval/episode_env_reward"], per_env.mean(), rtol=1e-5)
    totals.setdefault(actions, []).append(np.asarray(per_env))
  mean, = totals["mean"]
  assert np.ptp(mean) == 0.0                        # four copies of one episode
  first, again, other = totals["sampled"]
  assert np.ptp(first) > 1e-3 and len(set(first.tolist())) == 4   # four episodes
  np.testing.assert_array_equal(first, again)        # reproducible from its key
  assert not np.allclose(first, other)               # another key, other episodes
  assert not np.allclose(first, mean)


def test_the_evaluation_samples_by_default_and_a_bad_setting_names_the_valid_ones():
  assert training.PPOConfig().eval_actions == "sampled"  # the original's, blx's default
  with pytest.raises(ValueError, match=r"eval_actions must be one of 'sampled', 'mean' \(sampled "
                                       r"actions, the original's and blx's default, or the mean "
                                       r"action\), got 'greedy'"):
    training.PPOConfig(eval_actions="greedy")


def test_episode_settings_are_the_envs_and_bad_envs_are_named():
  with pytest.raises(ValueError, match="episode_length belong to the env, not to PPO"):
    training.ppo_defaults("point", episode_length=20)
  with pytest.raises(ValueError, match="action_repeat belong to the env"):
    SMALL.replace(action_repeat=2)
  base = envs.unwrap(point_goal())
  with pytest.raises(ValueError, match="make_trainer: the env has no time limit"):
    training.make_trainer(base, task(), SMALL)
  with pytest.raises(ValueError, match="already resets itself"):
    training.make_trainer(envs.auto_reset(envs.episode(base, 8)), task(), SMALL)
  with pytest.raises(ValueError, match=r"episode_length must be an int in 1..2\*\*31 - 1"):
    envs.register_env("bad_episode", {}, episode_length=0)


def test_staggered_starts_spread_the_episode_ends_and_keep_each_episode_whole():
  # 16 envs, 20-step episodes; one collect is 2 unrolls of 5 steps, so two collects cover one
  # episode length of every env. In step (the original), every env ends at step 20 together;
  # staggered, each env ends once, at 20 minus its random offset, and then runs a whole episode.
  env = envs.create("point", episode_length=20)
  for staggered in (False, True):
    config = SMALL.replace(staggered_starts=staggered)
    trainer = training.make_trainer(env, reach_latent(), config)
    state = jax.jit(trainer.init)(jax.random.PRNGKey(0))
    offsets = np.asarray(state.env_state.info["steps"])
    collect = jax.jit(trainer.collect)
    done = []
    for _ in range(6):  # 60 steps per env
      state, data = collect(state)
      # [U * N, T] -> [N, U * T]: each env's steps in order.
      per_env = np.asarray(data.done).reshape(config.num_unrolls, config.num_envs, -1)
      done.append(per_env.transpose(1, 0, 2).reshape(config.num_envs, -1))
    done = np.concatenate(done, axis=1)
    first_end = done.argmax(axis=1) + 1  # steps until each env's first episode ended
    if not staggered:
      assert (offsets == 0).all()
      assert (first_end == 20).all()
    else:
      assert offsets.min() >= 0 and offsets.max() < 20
      assert len(set(offsets.tolist())) >= 8, offsets  # 16 draws from 20 values
      np.testing.assert_array_equal(first_end, 20 - offsets)
    for row, end in zip(done, first_end):  # after the first end, whole 20-step episodes
      np.testing.assert_array_equal(np.flatnonzero(row), np.arange(end - 1, 60, 20))


def test_staggered_starts_by_default_only_above_the_originals_2048_envs():
  from blx.training.config import ppo_defaults
  assert SMALL.staggered_starts is None and not SMALL.starts_staggered
  assert not ppo_defaults("ant").starts_staggered  # the paper's 2,048 envs start together
  assert ppo_defaults("ant", num_envs=16384).starts_staggered
  assert not ppo_defaults("ant", num_envs=16384, staggered_starts=False).starts_staggered
  assert SMALL.replace(staggered_starts=True).starts_staggered
  # The trainer follows the resolved value: 4,096 envs (above 2,048) start at spread clocks.
  env = envs.create("point", episode_length=20)
  for num_envs, spread in ((2048, False), (4096, True)):
    config = SMALL.replace(num_envs=num_envs, batch_size=num_envs, num_minibatches=1)
    init = jax.jit(training.make_trainer(env, reach_latent(), config).init)
    offsets = np.asarray(init(jax.random.PRNGKey(0)).env_state.info["steps"])
    assert (len(set(offsets.tolist())) == 20) if spread else (offsets == 0).all(), num_envs


def test_a_checkpoint_without_env_state_is_smaller_and_a_run_resumes_from_it(tmp_path):
  env = envs.create("point", episode_length=20)
  config = SMALL.replace(num_evals=2)
  paths = {}
  for with_env in (True, False):
    paths[with_env] = str(tmp_path / f"ckpt_{with_env}")
    _stop_after_first_chunk(env, config.replace(checkpoint_env_state=with_env), paths[with_env])
  meta = checkpoint.read_meta(paths[False])
  assert meta["chunk"] == 1 and meta["env_state"] is False
  with np.load(checkpoint.path(paths[False])) as f:
    light = list(f.files)
  with np.load(checkpoint.path(paths[True])) as f:
    full = list(f.files)
  assert not any("env_state" in k for k in light) and any("env_state" in k for k in full)
  assert set(light) < set(full)
  assert os.path.getsize(checkpoint.path(paths[False])) < os.path.getsize(checkpoint.path(paths[True]))

  # Resuming restores everything saved and starts the envs anew: the run ends at the same step
  # count as an uninterrupted one, keeps the first chunk's history and trained on from its params.
  # The checkpoint says what it holds, whatever the config of the run that reads it.
  saved, _ = training.restore_state(paths[False], _like(env, config))
  assert saved.env_state is None and saved.params is not None
  result = training.train(env, reach_latent(), config.replace(checkpoint_env_state=False),
                          progress=False, checkpoint_dir=paths[False], resume=True)
  assert checkpoint.read_meta(paths[False])["chunk"] == 2 and len(result.metrics) == 2
  assert int(np.asarray(result.state.env_steps)[0]) == 2 * int(result.metrics[0]["env_steps"])
  before = jax.tree.leaves(saved.params)
  after = jax.tree.leaves(result.state.params)
  assert any(not np.array_equal(a, b) for a, b in zip(before, after))
  assert all(np.isfinite(np.asarray(x)).all() for x in after)


def test_dropping_the_env_state_keeps_the_rest_and_the_run_resumes(tmp_path):
  env = envs.create("point", episode_length=20)
  config = SMALL.replace(num_evals=2)  # checkpoint_env_state on, the default
  directory = str(tmp_path / "ckpt")
  _stop_after_first_chunk(env, config, directory)
  whole, whole_meta = training.restore_state(directory, _like(env, config))
  size = os.path.getsize(checkpoint.path(directory))
  training.drop_env_state(directory)
  light, meta = training.restore_state(directory, _like(env, config))
  assert light.env_state is None and whole.env_state is not None
  assert meta == {**whole_meta, "env_state": False}
  for a, b in zip(jax.tree.leaves(whole.replace(env_state=None)), jax.tree.leaves(light)):
    np.testing.assert_array_equal(a, b)
  assert os.path.getsize(checkpoint.path(directory)) < size
  result = training.train(env, reach_latent(), config, progress=False, checkpoint_dir=directory,
                          resume=True)
  assert len(result.metrics) == 2 and checkpoint.read_meta(directory)["env_state"] is True
  with pytest.raises(checkpoint.CheckpointError, match="no checkpoint at"):
    training.drop_env_state(str(tmp_path / "nothing"))


def _stop_after_first_chunk(env, config, directory):
  """Trains until the first chunk's checkpoint is written, then interrupts as Ctrl-C would."""
  def stop(row):
    raise KeyboardInterrupt

  with pytest.raises(KeyboardInterrupt):
    training.train(env, reach_latent(), config, progress=stop, checkpoint_dir=directory)


def _like(env, config):
  trainer = training.make_trainer(env, reach_latent(), config)
  return jax.eval_shape(jax.vmap(trainer.init), jnp.stack([jax.random.PRNGKey(0)]))


def test_a_checkpoint_from_before_a_setting_existed_resumes_with_its_default(tmp_path):
  env = envs.create("point", episode_length=20)
  config = SMALL.replace(num_evals=2)
  directory = str(tmp_path / "ckpt")
  _stop_after_first_chunk(env, config, directory)
  state, meta = training.restore_state(directory, _like(env, config))
  for name in ("checkpoint_env_state", "staggered_starts"):
    del meta["config"][name]  # as blx wrote it before the setting existed
  checkpoint.save(directory, state, meta)
  result = training.train(env, reach_latent(), config, progress=False, checkpoint_dir=directory,
                          resume=True)
  assert len(result.metrics) == 2
  # staggered_starts is compared as it ran: the default (None) chose off at 16 envs, as False does.
  assert checkpoint.read_meta(directory)["config"]["staggered_starts"] is False
  training.train(env, reach_latent(), config.replace(staggered_starts=False), progress=False,
                 checkpoint_dir=directory, resume=True)
  # A setting that differs from the checkpoint's is still refused.
  with pytest.raises(ValueError, match="different config"):
    training.train(env, reach_latent(), config.replace(checkpoint_env_state=False),
                   progress=False, checkpoint_dir=directory, resume=True)


def test_max_grad_norm_scales_each_gradient_to_its_global_norm_before_adam():
  """With ``max_grad_norm`` the optimiser's updates are plain Adam's on gradients scaled to that
  global norm (by hand), and differ from unclipped Adam's where the gradients' norms change from
  step to step (one Adam step alone hardly depends on the gradient's scale)."""
  import dataclasses

  import optax

  from blx.training import ppo
  params = {"w": jnp.ones((3, 2)), "b": jnp.zeros(2)}
  grads = [{"w": jnp.full((3, 2), 4.0), "b": jnp.array([3.0, -2.0])},
           {"w": jnp.full((3, 2), 0.1), "b": jnp.array([-0.2, 0.05])}]

  def updates(optimizer, gradients):
    state, out = optimizer.init(params), []
    for g in gradients:
      u, state = optimizer.update(g, state, params)
      out.append(u)
    return out

  def scaled(g, limit):
    norm = float(optax.global_norm(g))
    return jax.tree.map(lambda x: x * min(1.0, limit / norm), g)

  clipped = updates(ppo.make_learner(3, 2, task(), dataclasses.replace(
      SMALL, max_grad_norm=1.0)).optimizer, grads)
  by_hand = updates(optax.adam(SMALL.learning_rate), [scaled(g, 1.0) for g in grads])
  plain = updates(ppo.make_learner(3, 2, task(), SMALL).optimizer, grads)
  assert float(optax.global_norm(grads[0])) > 1.0 > float(optax.global_norm(grads[1]))
  for ours, theirs in zip(clipped, by_hand):
    jax.tree.map(lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9), ours, theirs)
  assert not np.allclose(clipped[1]["w"], plain[1]["w"], rtol=1e-3)


def _sgd_step_metrics(config, old_log_prob_shift=0.0):
  """The metrics of one PPO SGD step of a fresh learner on a tiny batch whose behaviour policy is
  the learner's own (its log-probabilities moved by ``old_log_prob_shift``)."""
  from blx.training import networks, ppo

  learner = ppo.make_learner(3, 2, task(), config)
  keys = jax.random.split(jax.random.PRNGKey(0), 6)
  params = ppo.Params(policy=learner.policy_net.init(keys[0], jnp.zeros(3)),
                      value=learner.value_net.init(keys[1], jnp.zeros(3)), objective=None)
  stats = networks.init_stats(3)
  obs = jax.random.normal(keys[2], (1, 4, 3))
  logits = learner.policy_net.apply(params.policy, learner.policy_input(stats, obs, None))
  raw = networks.sample_raw_action(logits, keys[3])
  reward = jax.random.normal(keys[4], (1, 4))
  batch = ppo.Rollout(obs=obs, raw_action=raw, action=jnp.tanh(raw),
                      log_prob=networks.log_prob_raw(logits, raw) + old_log_prob_shift,
                      next_obs=obs + 0.1, reward=reward, env_reward=reward,
                      done=jnp.zeros((1, 4)), truncation=jnp.zeros((1, 4)), z=jnp.zeros((1, 4, 0)))
  carry = (params, learner.optimizer.init(params), stats)
  return ppo.sgd_step(learner, carry, (batch, keys[5]))[1]


def test_log_ratio_max_is_the_largest_log_of_ppos_ratio():
  """``policy/log_ratio_max``: log pi - log pi_old at its largest over the batch; 0 where the
  batch came from the policy itself, 5 where its log-probabilities were 5 lower. exp of it
  overflows float32 above about 88.7, which is what the non-finite report gives it for."""
  assert float(_sgd_step_metrics(SMALL)["policy/log_ratio_max"]) == pytest.approx(0.0, abs=1e-5)
  shifted = _sgd_step_metrics(SMALL, old_log_prob_shift=-5.0)
  assert float(shifted["policy/log_ratio_max"]) == pytest.approx(5.0, abs=1e-5)
  assert not bool(shifted["nonfinite/grads"])


def test_an_updates_statistics_keep_a_max_statistics_largest_step_and_the_others_mean():
  from blx.training import ppo

  out = ppo.reduce_stats({"loss/total": jnp.array([1.0, 3.0, 5.0]),
                          "policy/log_ratio_max": jnp.array([2.0, 7.0, 4.0]),
                          "nonfinite/grads": jnp.array([False, False, False])})
  assert float(out["loss/total"]) == pytest.approx(3.0)
  assert float(out["policy/log_ratio_max"]) == 7.0
  assert "nonfinite/grads" not in out  # _first_nonfinite_step reports it
  # On the host over a chunk's iterations ([seeds, iterations]), as train's rows: per seed.
  rows = ppo.reduce_stats({"loss/total": np.array([[1.0, 3.0], [2.0, 6.0]]),
                           "policy/log_ratio_max": np.array([[2.0, 7.0], [9.0, 4.0]]),
                           "nonfinite/loss/policy": np.array([[False, True], [False, False]])},
                          axis=1, xp=np)
  np.testing.assert_allclose(rows["loss/total"], [2.0, 4.0])
  np.testing.assert_array_equal(rows["policy/log_ratio_max"], [7.0, 9.0])
  assert "nonfinite/loss/policy" not in rows


def test_grad_clipped_logs_whether_the_clip_scaled_the_step_down():
  """``grad_clipped`` is 1 for an SGD step whose gradient norm is above ``max_grad_norm`` and 0 for
  one below (the chunk's mean: the share of clipped steps); without a clip it is not logged."""
  import dataclasses

  step = _sgd_step_metrics
  plain = step(SMALL)
  norm = float(plain["grad_norm"])
  assert "grad_clipped" not in plain and norm > 0
  for limit, clipped in ((norm / 2, 1.0), (norm * 2, 0.0)):
    metrics = step(dataclasses.replace(SMALL, max_grad_norm=limit))
    assert float(metrics["grad_norm"]) == pytest.approx(norm, rel=1e-6)  # before the clip
    assert float(metrics["grad_clipped"]) == clipped


def test_off_row_names_the_settings_a_run_changed_from_its_envs_row():
  from blx.training.config import off_row, off_row_text
  row = training.ppo_defaults("halfcheetah")
  # the length and bookkeeping are not named; the clip and a changed learning rate are, in field
  # order; a setting at the row's value (a list read from JSON as the row's tuple) is not
  ppo = {"max_grad_norm": 5, "learning_rate": row.learning_rate / 2, "num_timesteps": 10,
         "num_evals": 40, "entropy_cost": row.entropy_cost}
  assert off_row("halfcheetah", ppo) == {"learning_rate": (row.learning_rate / 2,
                                                           row.learning_rate),
                                         "max_grad_norm": (5, None)}
  assert off_row_text("halfcheetah", ppo) == (
      f"PPO learning_rate {row.learning_rate / 2} (default {row.learning_rate}), max_grad_norm 5 "
      "(default None)")
  assert off_row("halfcheetah", {}) == {} and off_row_text("halfcheetah", None) == ""
  # the mean action is named where the return episodes are reported, and left out where not
  mean = {**ppo, "eval_actions": "mean"}
  assert off_row("halfcheetah", mean)["eval_actions"] == ("mean", "sampled")
  assert off_row("halfcheetah", mean, returns=False) == off_row("halfcheetah", ppo)
  assert off_row_text("halfcheetah", {"eval_actions": "mean"}, returns=False) == ""
  # each body is held to its own row: Ant's reward scaling is HalfCheetah's option, not Ant's
  ant = {"reward_scaling": training.ppo_defaults("ant").reward_scaling}
  assert off_row("ant", ant) == {}
  assert off_row("halfcheetah", ant) == {"reward_scaling": (ant["reward_scaling"],
                                                            row.reward_scaling)}


def test_first_nonfinite_step_reports_the_first_bad_sgd_step_not_the_ones_after_it():
  from blx.training.ppo import _first_nonfinite_step
  nan, inf = float("nan"), float("inf")
  # Step 1: PPO's ratio overflowed (log-ratio 90), an infinite policy term and total, and a NaN
  # gradient; from step 2 on, everything is NaN, as after a NaN parameter update.
  steps = {"loss/total": [1.0, inf, nan], "loss/policy": [0.5, inf, nan],
           "loss/value": [0.2, 0.3, nan], "loss/entropy": [0.0, 0.0, nan],
           "loss/objective": [0.3, 0.4, nan], "policy/log_ratio_max": [0.1, 90.0, nan],
           "nonfinite/grads": [False, True, True]}
  out = jax.device_get(_first_nonfinite_step({k: jnp.asarray(v) for k, v in steps.items()}))
  assert bool(out["nonfinite/grads"]) and bool(out["nonfinite/loss/policy"])
  assert not any(bool(out[f"nonfinite/loss/{t}"]) for t in ("value", "entropy", "objective"))
  assert float(out["nonfinite/log_ratio_max"]) == 90.0
  # A finite update reports nothing, and a log-ratio of 0.
  finite = {k: jnp.asarray(v[:1]) for k, v in steps.items()}
  out = jax.device_get(_first_nonfinite_step(finite))
  assert not any(bool(v) for k, v in out.items() if k != "nonfinite/log_ratio_max")
  assert float(out["nonfinite/log_ratio_max"]) == 0.0


def test_a_chunks_row_keeps_a_max_statistics_largest_and_the_others_mean():
  # One chunk of four iterations: the history row's policy/log_ratio_max is the largest of the
  # four iterations' values, its loss/policy their mean (the same chunk, run by hand).
  import dataclasses

  config = dataclasses.replace(SMALL, num_timesteps=4 * 160, num_evals=1)
  env = envs.create("point", episode_length=20)
  objective = reach_latent()
  trainer = training.make_trainer(env, objective, config)
  assert trainer.iterations_per_chunk == 4
  init_keys, _ = training.loop.run_keys([3])
  _, metrics = jax.jit(jax.vmap(trainer.chunk))(jax.vmap(trainer.init)(init_keys))
  ratio, policy = np.asarray(metrics["policy/log_ratio_max"]), np.asarray(metrics["loss/policy"])
  assert len(set(ratio[0].round(6))) > 1  # the iterations differ, so max and mean differ
  row = training.train(env, objective, config, seeds=(3,), progress=False).metrics[0]
  np.testing.assert_allclose(row["policy/log_ratio_max"], ratio.max(axis=1), rtol=1e-5)
  np.testing.assert_allclose(row["loss/policy"], policy.mean(axis=1), rtol=1e-4, atol=1e-7)


def test_config_as_trained_takes_the_checkpoints_settings_but_those_the_run_sets_itself():
  import dataclasses
  import json
  # A checkpoint's metadata as train writes it (through JSON: tuples come back as lists).
  then = training.PPOConfig(entropy_cost=0.1, policy_hidden=(64, 64), eval_actions="mean")
  recorded = {**dataclasses.asdict(then), "staggered_starts": then.starts_staggered}
  meta = {"config": json.loads(json.dumps(recorded))}
  # Defaults moved since; the run itself sets entropy_cost (its own, even where it differs).
  now = training.PPOConfig(entropy_cost=0.2, eval_actions="sampled")
  config, taken = training.config_as_trained(meta, now, own=("entropy_cost",))
  assert config == now.replace(eval_actions="mean", policy_hidden=(64, 64))
  assert taken == {"policy_hidden": ((64, 64), (32, 32, 32, 32)),
                   "eval_actions": ("mean", "sampled")}
  # Where nothing moved, nothing is taken: staggered_starts is recorded resolved (None chose off
  # at 2,048 envs), and a field the checkpoint does not record keeps the config's value.
  del meta["config"]["max_grad_norm"]
  same = then.replace(max_grad_norm=5.0)
  assert training.config_as_trained(meta, same) == (same, {})
  # A recorded True where None now chooses off (the rule moved) is kept as the run trained.
  meta["config"]["staggered_starts"] = True
  config, taken = training.config_as_trained(meta, then)
  assert config.starts_staggered and taken == {"staggered_starts": (True, None)}
  # A checkpoint from before eval_actions trained with the mean action (UNRECORDED_SETTINGS), also
  # where the default samples now; one that records no config at all leaves the config as it is.
  del meta["config"]["eval_actions"]
  sampled = same.replace(eval_actions="sampled", staggered_starts=True)
  config, taken = training.config_as_trained(meta, sampled)
  assert config.eval_actions == "mean" and taken == {"eval_actions": ("mean", "sampled")}
  assert training.config_as_trained({}, sampled) == (sampled, {})
