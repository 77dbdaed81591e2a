"""The host loop: runs the pure train step in chunks, evaluates, reports, checkpoints, resumes."""

from __future__ import annotations

import concurrent.futures
import dataclasses
import os
import sys
import threading
import time
from typing import Any, Callable, NamedTuple, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from blx import envs as envs_lib
from blx.objectives.base import Objective
from blx.training import checkpoint
from blx.training.config import PPOConfig, check_seeds
from blx.training.ppo import (PolicyParams, Trainer, TrainState, make_trainer, place_state,
                              policy_params, reduce_stats)

__all__ = ["TrainResult", "train", "run_keys", "NonFiniteError", "evaluate_together", "compile_all",
           "parallel_compile_default", "restore_state", "drop_env_state"]


class NonFiniteError(FloatingPointError):
  """Training produced a non-finite observation, reward, loss, gradient or parameter."""


class TrainResult(NamedTuple):
  """What ``train`` returns.

  Attributes:
    params: ``PolicyParams`` (normaliser, policy, objective), each leaf with a leading seed axis.
    metrics: one dict per evaluation: ``env_steps``, ``time`` (wall seconds of training so far,
      compilation included, summed over the processes of a resumed run), training means and
      ``eval/...`` values, each a list over seeds.
    policy: ``policy(params, obs, z=None, key=None, deterministic=True) -> action`` for one seed's
      params (``jax.tree.map(lambda x: x[i], result.params)``).
    state: the final ``TrainState`` (leading seed axis).
  """

  params: PolicyParams
  metrics: list[dict]
  policy: Callable[..., jax.Array]
  state: TrainState


_PROGRESS_KEYS = ("eval/episode_reward", "eval/episode_score", "disc/accuracy", "eval/mi",
                  "eval/lgr", "eval/energy_distance")


def print_progress(row: dict) -> None:
  """The line ``train(progress=True)`` prints after each evaluation (to stderr)."""
  evals = ", ".join(f"{k.split('/', 1)[1]} {np.mean(v):.3g}" for k, v in row.items()
                    if k in _PROGRESS_KEYS)
  print(f"[blx] steps {row['env_steps']:,.0f}/{row['total_steps']:,.0f}  "
        f"{row['steps_per_second']:,.0f} steps/s  ETA {row['eta_seconds']:.0f}s  {evals}",
        file=sys.stderr, flush=True)


def evaluate_together(trainer: Trainer, evaluate: Callable | None
                      ) -> Callable[[PolicyParams, jax.Array, jax.Array], dict]:
  """``(params, key, evaluator_key) -> metrics``: PPO's evaluation (``trainer.evaluate``) and, if
  given, ``evaluate(policy, params, evaluator_key)`` beside it, in one dict.

  An evaluator that hands over its episodes (``blx.metrics.Evaluator``: the paper's) on the env
  PPO evaluates on runs them in one rollout with PPO's episodes (``blx.envs.rollout_together``):
  both evaluations are long chains of small steps, bound by their latency on a GPU, so together
  they cost about one (``benchmarks/chunk_costs.py``). The metrics are those of each alone, up to
  the rounding of batched arithmetic. Other evaluators run after PPO's.
  """
  def evaluate_all(params, key, evaluator_key):
    if evaluate is None:
      return trainer.evaluate(params, key)
    episodes = getattr(evaluate, "episodes", None)
    if episodes is not None:
      ours, score = trainer.evaluation_episodes(params, key)
      theirs, their_score = episodes(trainer.policy, params, evaluator_key)
      if theirs.env is ours.env and theirs.steps == ours.steps:
        ours_records, their_records = envs_lib.rollout_together([ours, theirs])
        return {**score(ours_records), **their_score(their_records)}
    return {**trainer.evaluate(params, key), **evaluate(trainer.policy, params, evaluator_key)}

  return evaluate_all


def train(env: Any, objective: Objective, config: PPOConfig, *, seeds: Sequence[int] = (0,),
          progress: bool | Callable[[dict], None] = True, checkpoint_dir: str | None = None,
          resume: bool = False, evaluate: Callable | None = None,
          parallel_compile: bool | None = None) -> TrainResult:
  """Trains ``objective`` on ``env`` with PPO for every seed in one vmapped program.

  Args:
    env: an env from ``blx.envs.create``, run as given: its episode length and action repeat are
      its own (training adds auto-reset).
    objective: ``blx.objectives.task()`` or any ``Objective``.
    config: ``PPOConfig``; ``num_evals`` sets how often the host evaluates, reports and checkpoints.
    seeds: one training run per seed, vmapped.
    progress: True prints a line per evaluation; a callable receives each metrics row.
    checkpoint_dir: where to write the state after every chunk (atomically).
    resume: continue from the checkpoint in ``checkpoint_dir`` if there is one.
    evaluate: optional ``(policy, params, key) -> metrics`` run after every chunk beside PPO's
      evaluation (vmapped over seeds), e.g. ``blx.metrics.mimax_evaluator(env, objective)`` for
      MI, H(s), LGR and coverage curves; off by default for speed. The paper's evaluators on
      ``env`` step their episodes in one rollout with PPO's (``evaluate_together``).
    parallel_compile: compile the chunk and the evaluation at the same time, each in a thread of
      its own (``compile_all``). None (the default) decides by ``$BLX_PARALLEL_COMPILE`` (``1``
      or ``0``), else by the host: on where it has at least 8 cores.

  Raises:
    NonFiniteError: an observation, a reward, a loss, a gradient or a parameter became
      non-finite; the message names the iteration, the seed and the quantities (for a loss, its
      terms and PPO's largest log-ratio at the first bad SGD step), and the checkpoint of the
      last good chunk is kept.
    KeyboardInterrupt: passed on at once, with the checkpoint of the last chunk reported; the
      chunk in flight is dropped, and does not hold the process's exit.
  """
  seeds = list(check_seeds(seeds, "train: seeds"))
  trainer = make_trainer(env, objective, config)
  init_keys, eval_keys = run_keys(seeds)
  init_fn = jax.jit(jax.vmap(trainer.init))
  chunk_fn = jax.jit(jax.vmap(trainer.chunk))
  evaluate_all = evaluate_together(trainer, evaluate)
  eval_fn = jax.jit(jax.vmap(lambda state, key, evaluator_key: evaluate_all(
      policy_params(state), key, evaluator_key)))
  report = print_progress if progress is True else (progress or None)

  start_chunk, history, time_before = 0, [], 0.0
  # The checkpoint records staggered_starts resolved (None chooses by num_envs), as it ran.
  run_config = {**dataclasses.asdict(config), "staggered_starts": config.starts_staggered}
  meta_base = {"seeds": seeds, "config": run_config, "objective": objective.name,
               "num_chunks": trainer.num_chunks}
  if resume and checkpoint_dir and checkpoint.exists(checkpoint_dir):
    state, meta = restore_state(checkpoint_dir, jax.eval_shape(init_fn, init_keys))
    # A setting added after the checkpoint was written had its default's behaviour then
    # (staggered_starts: off).
    then = {**dataclasses.asdict(PPOConfig()), "staggered_starts": False}
    meta = {**meta, "config": {**then, **(meta.get("config") or {})}}
    for key in ("seeds", "config", "objective"):
      if _jsonable(meta.get(key)) != _jsonable(meta_base[key]):
        raise ValueError(f"resume: the checkpoint in {checkpoint_dir} was written with a different "
                         f"{key} ({meta.get(key)!r}); start a new run or use the same {key}")
    start_chunk, history = int(meta["chunk"]), list(meta.get("history", []))
    time_before = float(history[-1]["time"]) if history else 0.0
    if state.env_state is None:  # written with checkpoint_env_state=False: every env starts anew
      state = state.replace(env_state=init_fn(init_keys).env_state)
  else:
    state = init_fn(init_keys)
  # On several devices, the layout the chunk keeps its state in, which the programs compiled below
  # are compiled for (a restored state comes back on one device).
  state = place_state(state, config.num_envs)

  total = trainer.num_chunks * trainer.iterations_per_chunk * trainer.env_steps_per_iteration
  t0 = time.time()
  steps0 = start_chunk * trainer.iterations_per_chunk * trainer.env_steps_per_iteration
  # Compiled ahead of the first chunk, so that the reported steps/s and ETA leave compilation out
  # ("time" in the metrics is the wall time since the start, compilation included).
  if start_chunk < trainer.num_chunks:  # (a finished run resumed has nothing to compile)
    chunk_fn, eval_fn = compile_all(
        [lambda: chunk_fn.lower(state), lambda: eval_fn.lower(state, eval_keys, eval_keys)],
        parallel=parallel_compile)
  compile_seconds = time.time() - t0

  def dispatch(state, chunk):
    """Queues chunk ``chunk`` after ``state`` and the evaluations of its result on the device.
    Runs on the dispatch thread, which may wait there for the device (on a GPU, loops whose end
    depends on the data, as MJX's solver's, are checked from the launching thread)."""
    state, metrics = chunk_fn(*_as_compiled_for(chunk_fn, state))
    fold = jax.vmap(jax.random.fold_in, (0, None))
    evals = eval_fn(*_as_compiled_for(eval_fn, state, fold(eval_keys, chunk),
                                      fold(eval_keys, 1_000_003 + chunk)))
    return state, metrics, evals

  # Chunks are dispatched from a second thread, so that the host checks, checkpoints and reports
  # chunk k while the device runs chunk k + 1 (JAX's asynchronous dispatch alone did not overlap
  # them on a GPU: each report came one chunk late, benchmarks/RESULTS.md session 13).
  try:
    pending = (_in_background(dispatch, state, start_chunk)
               if start_chunk < trainer.num_chunks else None)
    for chunk in range(start_chunk, trainer.num_chunks):
      state, metrics, evals = pending.result()
      # The small results start for the host before the next chunk is queued behind them. A
      # chunk that fails the finite check raises below; the chunk queued after it is dropped.
      for leaf in jax.tree.leaves((metrics, evals)):
        leaf.copy_to_host_async()
      pending = (_in_background(dispatch, state, chunk + 1)
                 if chunk + 1 < trainer.num_chunks else None)
      metrics = jax.device_get(metrics)
      _check_finite(metrics, chunk * trainer.iterations_per_chunk, seeds, checkpoint_dir)
      evals = jax.device_get(evals)
      env_steps = float(np.asarray(state.env_steps)[0])
      elapsed = time.time() - t0
      rate = (env_steps - steps0) / max(elapsed - compile_seconds, 1e-9)
      row = {"env_steps": env_steps, "time": time_before + elapsed, "steps_per_second": rate,
             "total_steps": float(total), "eta_seconds": (total - env_steps) / max(rate, 1e-9),
             "compile_seconds": compile_seconds}
      per_seed = reduce_stats({k: np.asarray(v) for k, v in metrics.items()}, axis=1, xp=np)
      row.update({k: v.tolist() for k, v in per_seed.items()})  # over the chunk's iterations
      row.update({k: np.asarray(v).tolist() for k, v in evals.items()})
      history.append(row)
      if checkpoint_dir:
        saved = state if config.checkpoint_env_state else state.replace(env_state=None)
        checkpoint.save(checkpoint_dir, saved, {**meta_base, "chunk": chunk + 1,
                                                "history": history,
                                                "env_state": config.checkpoint_env_state})
      if report:
        report(row)
  except KeyboardInterrupt:
    if checkpoint_dir and checkpoint.exists(checkpoint_dir):
      done = checkpoint.read_meta(checkpoint_dir)["chunk"]
      print(f"[blx] interrupted; the checkpoint in {checkpoint_dir} holds {done}/"
            f"{trainer.num_chunks} chunks: call train(..., checkpoint_dir={checkpoint_dir!r}, "
            "resume=True) to continue", file=sys.stderr)
    raise

  return TrainResult(params=policy_params(state), metrics=history, policy=trainer.policy, state=state)


DISPATCH_THREAD = "blx-dispatch"  # the thread's name, by which ``cli.run_main`` finds it


def run_keys(seeds: Sequence[int]) -> tuple[jax.Array, jax.Array]:
  """``(init_keys, eval_keys)``, each ``[seeds, 2]``: the keys ``train`` derives from each seed
  for the training state (``Trainer.init``) and for the evaluations after each chunk."""
  keys = jnp.stack([jax.random.PRNGKey(s) for s in seeds])
  return (jax.vmap(lambda k: jax.random.split(k)[0])(keys),
          jax.vmap(lambda k: jax.random.split(k)[1])(keys))


def _as_compiled_for(compiled: Any, *args) -> tuple:
  """``args`` moved to the layout over devices that ``compiled`` (a ``jax.stages.Compiled``) was
  compiled for, which, unlike a jitted function, it does not do itself: a no-op where they are in
  it already (on one device, always)."""
  return tuple(jax.device_put(args, compiled.input_shardings[0]))


def _in_background(fn: Callable, *args) -> concurrent.futures.Future:
  """``fn(*args)`` on a daemon thread of its own; its result or exception in the future returned.

  A daemon thread, unlike an executor's, does not hold the process when training stops early
  (Ctrl-C, a non-finite loss): the chunk in flight is dropped, its checkpoint never written,
  rather than the interpreter waiting for it to end on the device (a whole chunk, minutes on a
  long run; benchmarks/RESULTS.md, session 30)."""
  future: concurrent.futures.Future = concurrent.futures.Future()

  def work():
    try:
      future.set_result(fn(*args))
    except BaseException as e:  # noqa: BLE001  (handed to the thread that waits on the future)
      future.set_exception(e)

  threading.Thread(target=work, name=DISPATCH_THREAD, daemon=True).start()
  return future


def drop_env_state(directory: str, *, compact: bool = False) -> None:
  """Rewrites the checkpoint in ``directory`` without the envs' simulator state, as if the run had
  been trained with ``PPOConfig.checkpoint_env_state=False``: what stays is the parameters,
  optimiser, normaliser and history, a small part of the file (an Ant row: 47 of 51 MB per seed
  are env state). For carrying a run's parameters off a machine once it is done or stopped;
  ``blx eval``, ``blx render`` and ``load_run`` read the result, and a resume starts every env on a
  new episode. ``compact``: written compact (``checkpoint.save``), smaller still and as exact.
  The rewrite is atomic: the whole checkpoint stays until the new one is in place."""
  checkpoint.rewrite(directory, keep=lambda key: not key.startswith(".env_state"),
                     meta_update={"env_state": False}, compact=compact)


PARALLEL_COMPILE_ENV = "BLX_PARALLEL_COMPILE"
_PARALLEL_COMPILE_MIN_CORES = 8


def parallel_compile_default() -> bool:
  """Whether ``train`` compiles its programs in parallel when not told: ``$BLX_PARALLEL_COMPILE``
  (``1``/``on``/``true`` or ``0``/``off``/``false``) if set, else whether the host has at least 8
  cores. On 2 cores it did not pay (benchmarks/RESULTS.md, session 12): XLA's compiler already
  uses both."""
  setting = os.environ.get(PARALLEL_COMPILE_ENV, "").strip().lower()
  if setting in ("1", "on", "true", "yes"):
    return True
  if setting in ("0", "off", "false", "no"):
    return False
  if setting:
    raise ValueError(f"${PARALLEL_COMPILE_ENV}={setting!r}: valid values are 1/on/true and "
                     "0/off/false (unset: on where the host has at least "
                     f"{_PARALLEL_COMPILE_MIN_CORES} cores)")
  return (os.cpu_count() or 1) >= _PARALLEL_COMPILE_MIN_CORES


def compile_all(lowerings: Sequence[Callable[[], Any]], *, parallel: bool | None = None) -> list:
  """Each ``lowering() -> jax.stages.Lowered`` compiled; the compiled programs, in order.

  In parallel, each program compiles in a thread of its own as soon as it is lowered, while the
  next one is traced and lowered on this thread: tracing holds Python's lock, but XLA's compiler
  runs outside it, so program k compiles while program k + 1 is traced and all compile at once.
  Otherwise one after the other. ``parallel=None``: :func:`parallel_compile_default`.
  """
  if parallel is None:
    parallel = parallel_compile_default()
  if not parallel or len(lowerings) < 2:
    return [lowering().compile() for lowering in lowerings]
  with concurrent.futures.ThreadPoolExecutor(len(lowerings),
                                             thread_name_prefix="blx-compile") as pool:
    futures = [pool.submit(lowering().compile) for lowering in lowerings]
    return [future.result() for future in futures]


def restore_state(directory: str, like: TrainState) -> tuple[TrainState, dict]:
  """The training state in the checkpoint in ``directory``, in the structure of ``like`` (shapes of
  the vmapped ``TrainState``), and its metadata. Its ``env_state`` is None where the checkpoint was
  written without it (``PPOConfig.checkpoint_env_state=False``)."""
  if not checkpoint.read_meta(directory).get("env_state", True):
    like = like.replace(env_state=None)
  return checkpoint.restore(directory, like)


def _jsonable(x):
  import json
  return json.loads(json.dumps(x))


def _check_finite(metrics: dict, first_iteration: int, seeds, checkpoint_dir) -> None:
  """Raises at the first iteration (and seed) where anything went non-finite, naming every
  quantity that did there: a non-finite observation points at the physics, a non-finite reward
  with finite observations at the objective's reward, a non-finite loss or gradient at the
  learning. For the loss, the terms that were non-finite at the update's first bad SGD step are
  named, with PPO's largest log-ratio there (``ppo._first_nonfinite_step``): one above about 88.7
  overflowed the ratio."""
  quantities = [q for q in ("observation", "reward", "loss", "grads", "params")
                if f"nonfinite/{q}" in metrics]
  flags = {q: np.asarray(metrics[f"nonfinite/{q}"]) for q in quantities}  # [seeds, iterations]
  bad = np.any(np.stack(list(flags.values())), axis=0)
  if not bad.any():
    return
  seed_idx, it = min(np.argwhere(bad), key=lambda x: (x[1], x[0]))
  which = [q + (_loss_detail(metrics, seed_idx, it) if q == "loss" else "")
           for q in quantities if flags[q][seed_idx, it]]
  kept = ""
  if checkpoint_dir:
    kept = (f"; the last good checkpoint in {checkpoint_dir} is kept"
            if checkpoint.exists(checkpoint_dir) else
            f"; no checkpoint had been written to {checkpoint_dir} yet")
  raise NonFiniteError(f"non-finite {' and '.join(which)} at iteration "
                       f"{first_iteration + int(it)} (seed {seeds[int(seed_idx)]}){kept}")


def _loss_detail(metrics: dict, seed_idx, it) -> str:
  """E.g. `` (its policy term at the first non-finite SGD step, where the largest log-ratio of pi
  to pi_old was 91.3)``; "" where the update logged no term."""
  terms = [k.rsplit("/", 1)[1] for k in metrics
           if k.startswith("nonfinite/loss/") and np.asarray(metrics[k])[seed_idx, it]]
  if not terms:
    return ""
  detail = (f" (its {' and '.join(terms)} term{'s' if len(terms) > 1 else ''} at the first "
            "non-finite SGD step")
  if "nonfinite/log_ratio_max" in metrics:
    ratio = float(np.asarray(metrics["nonfinite/log_ratio_max"])[seed_idx, it])
    detail += f", where the largest log-ratio of pi to pi_old was {ratio:.4g}"
  return detail + ")"
