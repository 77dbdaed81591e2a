"""benchmarks/device_scaling.py: its arguments are read or refused by name, and a process that does
not see the device count it was started for refuses to measure rather than mislabel its row."""

import types

import pytest

from tests.experiments import load_benchmark

device_scaling = load_benchmark("device_scaling")


def test_env_params_and_device_counts_are_read_and_bad_ones_named():
  assert device_scaling.env_params(["num_legs=4", "step=original", "scale=0.5"]) == {
      "num_legs": 4, "step": "original", "scale": 0.5}
  with pytest.raises(SystemExit, match=r"--env-param takes KEY=VALUE, got 'num_legs'"):
    device_scaling.env_params(["num_legs"])
  assert device_scaling.device_counts("1,2,4") == [1, 2, 4]
  for bad in ("0,1", "1,1", "two", ""):
    with pytest.raises(SystemExit, match=r"--devices takes distinct counts of at least 1"):
      device_scaling.device_counts(bad)


def test_a_process_that_sees_another_device_count_refuses_to_measure():
  import jax
  seen = len(jax.local_devices())
  args = types.SimpleNamespace(env="point", env_param=[], num_envs=None, chunks=1, iterations=1,
                               seeds=1)
  with pytest.raises(SystemExit, match=rf"asked for {seen + 1} devices, this process sees {seen}"):
    device_scaling.measure(args, seen + 1)


def test_the_pieces_timed_are_a_chunk_of_the_asked_iterations_and_ppos_evaluation():
  """``time_pieces`` times the trainer's own chunk, of ``--piece-iterations`` iterations, and its
  own evaluation, with a key per seed of the state; per iteration and per call."""
  import jax

  from blx import envs, training
  from blx.objectives import task

  env = envs.create("point")
  config = training.ppo_defaults("point").replace(num_envs=4, batch_size=4, num_minibatches=1,
                                                  unroll_length=2, num_timesteps=16, num_evals=1)
  trainer = training.make_trainer(env, task(), config)
  lengths, eval_keys = [], []

  def chunk(state, length):
    lengths.append(length)
    return trainer.chunk(state, length)

  def evaluate(params, key):
    eval_keys.append(key.shape)
    return trainer.evaluate(params, key)

  state = jax.jit(jax.vmap(trainer.init))(jax.random.split(jax.random.PRNGKey(0), 3))
  spy = trainer._replace(chunk=chunk, evaluate=evaluate)
  pieces = device_scaling.time_pieces(spy, state, iterations=3, repeats=2)
  assert lengths == [3]            # traced once: the chunk of the asked length
  assert eval_keys == [(2,)]       # traced once under vmap: one key per seed of the state's 3
  assert set(pieces) == {"iteration_s", "evaluation_s"}
  assert all(v > 0 for v in pieces.values())


def test_speedups_compare_the_run_by_its_rate_and_each_piece_by_its_seconds():
  first = {"steps_per_s": 100.0, "iteration_s": 2.0, "evaluation_s": 10.0}
  row = device_scaling.speedups({"steps_per_s": 150.0, "iteration_s": 1.0, "evaluation_s": 10.0},
                                first)
  assert (row["speedup"], row["iteration_speedup"], row["evaluation_speedup"]) == (1.5, 2.0, 1.0)
  assert device_scaling.speedups(first, first)["speedup"] == 1.0
