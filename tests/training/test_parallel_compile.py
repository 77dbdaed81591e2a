"""The host loop compiles its programs in parallel: each compiles while the next is traced, the
programs are those of a serial compile, and the switch reads its setting strictly."""

from __future__ import annotations

import threading

import jax
import numpy as np
import pytest

from blx import envs, training
from blx.training import loop
from tests.training.tiny import SMALL, reach_latent


class _Program:
  """Stands in for a ``jax.stages.Lowered``: its compile waits until ``ready`` is set."""

  def __init__(self, name, ready, log):
    self.name, self.ready, self.log = name, ready, log

  def compile(self):
    if not self.ready.wait(timeout=5):
      raise TimeoutError(f"{self.name} compiled before the next program was lowered")
    self.log.append(("compiled", self.name, threading.current_thread().name))
    return self.name


def _lowerings(log):
  # The first program's compile can only finish once the second has been lowered: it must run
  # while the second is traced, as on a GPU host the chunk compiles while the evaluation traces.
  second_lowered = threading.Event()
  done = threading.Event()
  done.set()

  def first():
    log.append(("lowered", "chunk"))
    return _Program("chunk", second_lowered, log)

  def second():
    log.append(("lowered", "evaluation"))
    second_lowered.set()
    return _Program("evaluation", done, log)
  return [first, second]


def test_in_parallel_a_program_compiles_while_the_next_is_lowered():
  log = []
  assert loop.compile_all(_lowerings(log), parallel=True) == ["chunk", "evaluation"]
  assert log[:2] == [("lowered", "chunk"), ("lowered", "evaluation")]
  compiled = log[2:]
  assert sorted(name for _, name, _ in compiled) == ["chunk", "evaluation"]
  assert all(thread.startswith("blx-compile") for _, _, thread in compiled)


def test_serially_each_program_compiles_before_the_next_is_lowered():
  # The same programs one after the other: the first compile waits for a lowering that never
  # comes, which is how a serial compile shows itself here.
  with pytest.raises(TimeoutError, match="chunk compiled before"):
    loop.compile_all(_lowerings([]), parallel=False)


def test_training_compiled_in_parallel_equals_training_compiled_serially():
  env = envs.create("point", episode_length=20)
  runs = [training.train(env, reach_latent(), SMALL, seeds=(0, 1), progress=False,
                         parallel_compile=parallel) for parallel in (False, True)]
  for a, b in zip(runs[0].metrics, runs[1].metrics):
    assert a["env_steps"] == b["env_steps"]
    np.testing.assert_allclose(a["eval/episode_reward"], b["eval/episode_reward"], rtol=1e-6)
  for a, b in zip(jax.tree.leaves(runs[0].params), jax.tree.leaves(runs[1].params)):
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("setting, expected", [("1", True), ("on", True), ("0", False),
                                               ("off", False), ("False", False)])
def test_the_environment_variable_decides_the_default(monkeypatch, setting, expected):
  monkeypatch.setenv(loop.PARALLEL_COMPILE_ENV, setting)
  assert loop.parallel_compile_default() is expected


def test_unset_the_default_follows_the_hosts_cores(monkeypatch):
  monkeypatch.delenv(loop.PARALLEL_COMPILE_ENV, raising=False)
  monkeypatch.setattr(loop.os, "cpu_count", lambda: 2)
  assert loop.parallel_compile_default() is False  # session 12: no gain on 2 cores
  monkeypatch.setattr(loop.os, "cpu_count", lambda: 16)
  assert loop.parallel_compile_default() is True


def test_a_bad_setting_is_refused_with_the_valid_values(monkeypatch):
  monkeypatch.setenv(loop.PARALLEL_COMPILE_ENV, "maybe")
  with pytest.raises(ValueError, match=r"BLX_PARALLEL_COMPILE='maybe'.*1/on/true and 0/off/false"):
    loop.parallel_compile_default()
