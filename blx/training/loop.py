"""The host loop: runs the pure train step in chunks, evaluates, reports, checkpoints, resumes."""

from __future__ import annotations

import concurrent.futures
import dataclasses
import os
import sys
import threading
import time
from typing import Any, Callable, Collection, NamedTuple, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from blx import envs as envs_lib
from blx.objectives.base import Objective
from blx.training import checkpoint
from blx.training.config import UNRECORDED_SETTINGS, PPOConfig, check_seeds
from blx.training.ppo import (PolicyParams, Trainer, TrainState, make_trainer, place_state,
                              policy_params, reduce_stats)

__all__ = ["TrainResult", "train", "run_keys", "NonFiniteError", "evaluate_together", "compile_all",
           "parallel_compile_default", "restore_state", "drop_env_state", "segment_length",
           "checkpoint_finished", "checkpoint_progress", "checkpoint_env_steps",
           "config_as_trained", "TimeLimitReached", "stop_time"]


class NonFiniteError(FloatingPointError):
  """Training produced a non-finite observation, reward, loss, gradient or parameter."""


class TimeLimitReached(KeyboardInterrupt):
  """``train`` stopped before a segment that would have ended past its time limit (``stop_by``):
  the checkpoint holds every segment before it. A ``KeyboardInterrupt``, so that whatever ends a
  run stopped by Ctrl-C (its checkpoint kept, its sweep stopped with the command that continues
  it, ``blx``'s exit status 130) ends this one the same way."""


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
  _print_steps(row["env_steps"], row["total_steps"], row["steps_per_second"],
               row["eta_seconds"], evals)


def _print_steps(steps: float, total: float, rate: float, eta: float, tail: str) -> None:
  """``train``'s progress line (to stderr): where the run stands, its pace, then ``tail``."""
  print(f"[blx] steps {steps:,.0f}/{total:,.0f}  {rate:,.0f} steps/s  ETA {eta:.0f}s  {tail}",
        file=sys.stderr, flush=True)


class SegmentDone(NamedTuple):
  """Where a run stands after a segment that ends within its chunk (``train``'s
  ``checkpoint_segments``): no evaluation and no metrics row, but a checkpoint where the run has a
  ``checkpoint_dir``. ``train(on_segment=...)`` receives one after each such segment."""
  chunk: int                  # the chunk the segment is in, counted from 1
  iterations: int             # the chunk's iterations done
  iterations_per_chunk: int
  env_steps: float            # per seed
  total_steps: float
  steps_per_second: float     # since this process began training, compilation left out
  eta_seconds: float
  checkpoint_dir: str | None  # where the state was checkpointed; None: nowhere

  def where(self) -> str:
    """"46 of 92 iterations of chunk 3; checkpointed" (or "not checkpointed")."""
    saved = "checkpointed" if self.checkpoint_dir else "not checkpointed"
    return (f"{self.iterations} of {self.iterations_per_chunk} iterations of chunk {self.chunk}; "
            f"{saved}")


def print_segment(done: SegmentDone) -> None:
  """The line ``train(progress=True)`` prints after a segment within a chunk (to stderr), as its
  line after an evaluation, but for the metrics, which come at the chunk's end."""
  _print_steps(done.env_steps, done.total_steps, done.steps_per_second, done.eta_seconds,
               f"({done.where()})")


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
          parallel_compile: bool | None = None,
          checkpoint_segments: int | None = None,
          on_segment: Callable[[SegmentDone], None] | None = None,
          stop_by: float | None = None) -> TrainResult:
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
    checkpoint_segments: run each chunk as this many segments of its iterations, checkpointing
      after each (evaluations, reports and the metrics' rows stay one per chunk), so that a run
      stopped mid-chunk (a device call's time limit) keeps all but its last segment. The
      iterations, and so the run, are the same (tested bit for bit on CPU). None (the default)
      reads ``$BLX_CHECKPOINT_SEGMENTS``, else 1. At most the chunk's iterations; a resumed run
      may use another number than the one it stopped with.
    on_segment: receives a ``SegmentDone`` after each segment that ends within its chunk (after
      its checkpoint). None (the default) prints ``print_segment``'s line where ``progress`` is
      True, and else nothing.
    stop_by: a time limit, as a Unix time in seconds (``time.time()``'s): after each segment, once
      its checkpoint is written, the run stops where the next segment would end after it, at the
      pace of the segments so far (each one's seconds an iteration, and an evaluation's extra
      seconds; the first segment always runs). The next segment, already queued on the device,
      is dropped. So a run given the time it may use (a job's or a device call's limit) ends on
      its own with all it trained kept, instead of losing the segment in flight to a kill. None
      (the default) reads ``$BLX_STOP_BY``, else no limit.

  Raises:
    NonFiniteError: an observation, a reward, a loss, a gradient or a parameter became
      non-finite; the message names the iteration, the seed and the quantities (for a loss, its
      terms and PPO's largest log-ratio at the first bad SGD step), and the checkpoint of the
      last good chunk (or segment) is kept.
    KeyboardInterrupt: passed on at once, with the checkpoint of the last chunk (or segment)
      reported; the chunk in flight is dropped, and does not hold the process's exit.
    TimeLimitReached: (a ``KeyboardInterrupt``) the next segment would end past ``stop_by``.
  """
  seeds = list(check_seeds(seeds, "train: seeds"))
  trainer = make_trainer(env, objective, config)
  per_chunk = trainer.iterations_per_chunk
  segment = segment_length(per_chunk, checkpoint_segments)
  stop_by = stop_time(stop_by)
  init_keys, eval_keys = run_keys(seeds)
  init_fn = jax.jit(jax.vmap(trainer.init))
  evaluate_all = evaluate_together(trainer, evaluate)
  eval_fn = jax.jit(jax.vmap(lambda state, key, evaluator_key: evaluate_all(
      policy_params(state), key, evaluator_key)))
  report = print_progress if progress is True else (progress or None)
  if on_segment is None and progress is True:
    on_segment = print_segment

  start_chunk, history, time_before = 0, [], 0.0
  done_in_chunk, partial_metrics = 0, []   # a resume mid-chunk: its segments run so far
  # The checkpoint records staggered_starts resolved (None chooses by num_envs), as it ran.
  run_config = {**dataclasses.asdict(config), "staggered_starts": config.starts_staggered}
  meta_base = {"seeds": seeds, "config": run_config, "objective": objective.name,
               "num_chunks": trainer.num_chunks}
  if resume and checkpoint_dir and checkpoint.exists(checkpoint_dir):
    state, meta = restore_state(checkpoint_dir, jax.eval_shape(init_fn, init_keys))
    # A setting added after the checkpoint was written had its default's behaviour then
    # (staggered_starts: off; eval_actions and any other whose default moved since:
    # UNRECORDED_SETTINGS).
    then = {**dataclasses.asdict(PPOConfig()), "staggered_starts": False, **UNRECORDED_SETTINGS}
    meta = {**meta, "config": {**then, **(meta.get("config") or {})}}
    for key in ("seeds", "config", "objective"):
      if _jsonable(meta.get(key)) != _jsonable(meta_base[key]):
        raise ValueError(f"resume: the checkpoint in {checkpoint_dir} was written with a different "
                         f"{key} ({meta.get(key)!r}); start a new run or use the same {key}")
    start_chunk, history = int(meta["chunk"]), list(meta.get("history", []))
    time_before = float(history[-1]["time"]) if history else 0.0
    if meta.get("partial"):
      done_in_chunk = int(meta["partial"]["iterations"])
      partial_metrics = [_metrics_from_json(meta["partial"]["metrics"])]
      time_before = float(meta["partial"]["time"])
    if state.env_state is None:  # written with checkpoint_env_state=False: every env starts anew
      state = state.replace(env_state=init_fn(init_keys).env_state)
  else:
    state = init_fn(init_keys)
  # On several devices, the layout the chunk keeps its state in, which the programs compiled below
  # are compiled for (a restored state comes back on one device).
  state = place_state(state, config.num_envs)

  total = trainer.num_chunks * per_chunk * trainer.env_steps_per_iteration
  pieces = _segments(start_chunk, done_in_chunk, trainer.num_chunks, per_chunk, segment)
  t0 = time.time()
  steps0 = _env_steps(state)
  # Compiled ahead of the first chunk, so that the reported steps/s and ETA leave compilation out
  # ("time" in the metrics is the wall time since the start, compilation included).
  segment_fns = {}   # iterations -> the program that runs them: at most three lengths
  if pieces:  # (a finished run resumed has nothing to compile)
    lengths = sorted({length for _, _, length in pieces})
    *programs, eval_fn = compile_all(
        [*(lambda n=n: jax.jit(jax.vmap(lambda state: trainer.chunk(state, n))).lower(state)
           for n in lengths),
         lambda: eval_fn.lower(state, eval_keys, eval_keys)], parallel=parallel_compile)
    segment_fns = dict(zip(lengths, programs))
  compile_seconds = time.time() - t0

  def dispatch(state, piece):
    """Queues segment ``piece`` after ``state`` and, where it ends its chunk, the evaluations of its
    result on the device. Runs on the dispatch thread, which may wait there for the device (on a
    GPU, loops whose end depends on the data, as MJX's solver's, are checked from the launching
    thread)."""
    chunk, first, length = piece
    fn = segment_fns[length]
    state, metrics = fn(*_as_compiled_for(fn, state))
    if first + length < per_chunk:
      return state, metrics, None
    fold = jax.vmap(jax.random.fold_in, (0, None))
    evals = eval_fn(*_as_compiled_for(eval_fn, state, fold(eval_keys, chunk),
                                      fold(eval_keys, 1_000_003 + chunk)))
    return state, metrics, evals

  def pace(state):
    """The env steps ``state`` has trained, the seconds since ``t0``, the env steps a second since
    ``t0`` (compilation left out) and the seconds the run's other steps would take at that rate."""
    env_steps, elapsed = _env_steps(state), time.time() - t0
    rate = (env_steps - steps0) / max(elapsed - compile_seconds, 1e-9)
    return env_steps, elapsed, rate, (total - env_steps) / max(rate, 1e-9)

  # Segments are dispatched from a second thread, so that the host checks, checkpoints and reports
  # segment k while the device runs segment k + 1 (JAX's asynchronous dispatch alone did not
  # overlap them on a GPU: each report came one chunk late, benchmarks/RESULTS.md session 13).
  try:
    pending = _in_background(dispatch, state, pieces[0]) if pieces else None
    clock = _SegmentClock()
    for i, (chunk, first, length) in enumerate(pieces):
      state, metrics, evals = pending.result()
      # The small results start for the host before the next segment is queued behind them. A
      # segment that fails the finite check raises below; the one queued after it is dropped.
      for leaf in jax.tree.leaves((metrics, evals)):
        leaf.copy_to_host_async()
      pending = _in_background(dispatch, state, pieces[i + 1]) if i + 1 < len(pieces) else None
      metrics = jax.device_get(metrics)
      if evals is not None:
        evals = jax.device_get(evals)
      clock.ended(length, evaluated=evals is not None)
      _check_finite(metrics, chunk * per_chunk + first, seeds, checkpoint_dir)
      partial_metrics.append({k: np.asarray(v) for k, v in metrics.items()
                              if not k.startswith("nonfinite/")})
      if evals is None:   # mid-chunk: a checkpoint, no row
        env_steps, elapsed, rate, eta = pace(state)
        if checkpoint_dir:
          partial = {"iterations": first + length, "time": time_before + elapsed,
                     "metrics": _metrics_to_json(_join(partial_metrics))}
          _save(checkpoint_dir, state, config, {**meta_base, "chunk": chunk, "history": history,
                                                "partial": partial})
        if on_segment:
          on_segment(SegmentDone(chunk + 1, first + length, per_chunk, env_steps, float(total),
                                 rate, eta, checkpoint_dir))
        _stop_if_late(stop_by, clock, pieces[i + 1:], per_chunk)
        continue
      env_steps, elapsed, rate, eta = pace(state)
      row = {"env_steps": env_steps, "time": time_before + elapsed, "steps_per_second": rate,
             "total_steps": float(total), "eta_seconds": eta,
             "compile_seconds": compile_seconds}
      per_seed = reduce_stats(_join(partial_metrics), axis=1, xp=np)
      partial_metrics = []
      row.update({k: v.tolist() for k, v in per_seed.items()})  # over the chunk's iterations
      row.update({k: np.asarray(v).tolist() for k, v in evals.items()})
      history.append(row)
      if checkpoint_dir:
        _save(checkpoint_dir, state, config, {**meta_base, "chunk": chunk + 1,
                                              "history": history})
      if report:
        report(row)
      _stop_if_late(stop_by, clock, pieces[i + 1:], per_chunk)
  except KeyboardInterrupt as stop:
    if checkpoint_dir and checkpoint.exists(checkpoint_dir):
      progress = checkpoint_progress(checkpoint.read_meta(checkpoint_dir), per_chunk)
      what = "stopped at the time limit" if isinstance(stop, TimeLimitReached) else "interrupted"
      print(f"[blx] {what}; the checkpoint in {checkpoint_dir} holds {progress}: call "
            f"train(..., checkpoint_dir={checkpoint_dir!r}, resume=True) to continue",
            file=sys.stderr)
    raise

  return TrainResult(params=policy_params(state), metrics=history, policy=trainer.policy, state=state)


DISPATCH_THREAD = "blx-dispatch"  # the thread's name, by which ``cli.run_main`` finds it
STOP_BY_ENV = "BLX_STOP_BY"


def stop_time(stop_by: float | None = None) -> float | None:
  """``train``'s time limit as a Unix time in seconds: ``stop_by``, or where it is None,
  ``$BLX_STOP_BY`` (e.g. ``BLX_STOP_BY=$(( $(date +%s) + 3600 ))``: an hour from now), else None
  (no limit). Refuses anything but a finite number, naming where it came from."""
  where = "stop_by"
  if stop_by is None:
    setting = os.environ.get(STOP_BY_ENV, "").strip()
    if not setting:
      return None
    where = f"${STOP_BY_ENV}"
    try:
      stop_by = float(setting)
    except ValueError:
      stop_by = setting   # refused below
  if (isinstance(stop_by, bool) or not isinstance(stop_by, (int, float, np.integer, np.floating))
      or not np.isfinite(stop_by)):
    raise ValueError(f"{where}={stop_by!r}: give the time limit as a Unix time in seconds, e.g. "
                     f"$(( $(date +%s) + 3600 )) for an hour from now")
  return float(stop_by)


class _SegmentClock:
  """The pace of a run's segments on the device, for ``train``'s time limit: seconds an
  iteration (from the last segment without an evaluation; until there is one, from the last
  segment, its evaluation included) and an evaluation's extra seconds. A segment's time runs
  from the end of the one before (the next is queued before the host checks and checkpoints a
  segment, so that host work does not count) or, for the first, from its dispatch."""

  def __init__(self):   # made as the first segment is queued
    self.last = time.time()
    self.per_iteration: float | None = None
    self.evaluation = 0.0
    self._measured = False   # per_iteration from a segment without an evaluation

  def ended(self, iterations: int, evaluated: bool) -> None:
    now = time.time()
    seconds, self.last = now - self.last, now
    if not evaluated:
      self.per_iteration, self._measured = seconds / iterations, True
    elif not self._measured:
      self.per_iteration = seconds / iterations
    else:
      self.evaluation = max(seconds - iterations * self.per_iteration, 0.0)

  def next_ends(self, iterations: int, evaluates: bool) -> float:
    """When a segment of ``iterations``, queued at the end of the last, would end (Unix time)."""
    return self.last + iterations * self.per_iteration + (self.evaluation if evaluates else 0.0)


def _stop_if_late(stop_by: float | None, clock: _SegmentClock, left: list, per_chunk: int) -> None:
  """Raises ``TimeLimitReached`` where the next of the segments ``left`` would end past
  ``stop_by`` (the one just checkpointed is kept; the next, already queued, is dropped)."""
  if stop_by is None or not left:
    return
  chunk, first, length = left[0]
  ends = clock.next_ends(length, evaluates=first + length == per_chunk)
  if ends > stop_by:
    print(f"[blx] time limit: stopping before iterations {first + 1}-{first + length} of chunk "
          f"{chunk + 1}, which would end about {ends - stop_by:.0f} s past it "
          f"({time.strftime('%H:%M:%S', time.localtime(stop_by))})", file=sys.stderr)
    raise TimeLimitReached(f"the next segment would end {ends - stop_by:.0f} s past the limit")


def run_keys(seeds: Sequence[int]) -> tuple[jax.Array, jax.Array]:
  """``(init_keys, eval_keys)``, each ``[seeds, 2]``: the keys ``train`` derives from each seed
  for the training state (``Trainer.init``) and for the evaluations after each chunk."""
  keys = jnp.stack([jax.random.PRNGKey(s) for s in seeds])
  return (jax.vmap(lambda k: jax.random.split(k)[0])(keys),
          jax.vmap(lambda k: jax.random.split(k)[1])(keys))


def checkpoint_finished(meta: dict) -> bool:
  """Whether a checkpoint's metadata (``train``'s) is a whole run's: every chunk trained, none cut
  within. A checkpoint that does not count its chunks (``num_chunks``; older than the count, or a
  run's meta built from its result, which is whole) is taken as finished."""
  total = meta.get("num_chunks")
  return total is None or (meta.get("chunk") == total and not meta.get("partial"))


def checkpoint_env_steps(meta: dict) -> float | None:
  """The env steps per seed the state of a checkpoint (its metadata, ``train``'s) has trained: its
  own count, which for a run trained in segments and stopped mid-chunk is past its last
  evaluation; else, for a checkpoint written before the count, its last evaluation's; None for
  neither."""
  steps = meta.get("env_steps")
  if steps is None:
    steps = ((meta.get("history") or [{}])[-1]).get("env_steps")
  return None if steps is None else float(steps)


def checkpoint_progress(meta: dict, iterations_per_chunk: int | None = None) -> str:
  """Where a checkpoint stands, from its metadata: "3 of 20 chunks and 46 iterations of the next"
  ("46 of 92 iterations" given the chunk's iterations)."""
  within = (meta.get("partial") or {}).get("iterations")
  of = f" of {iterations_per_chunk}" if iterations_per_chunk else ""
  return (f"{meta.get('chunk')} of {meta.get('num_chunks')} chunks"
          + (f" and {within}{of} iterations of the next" if within else ""))


def config_as_trained(meta: dict, config: PPOConfig,
                      own: Collection[str] = ()) -> tuple[PPOConfig, dict[str, tuple]]:
  """``config`` with the settings a checkpoint's metadata (``train``'s) recorded it trained with,
  where they differ, but for the fields named in ``own``; and ``{field: (the recorded value,
  config's)}`` for each one taken. A run's settings are its PPO row with the few it sets itself
  (``own``), so where blx's defaults moved since the checkpoint was written, this is the config
  that resumes it (``train`` refuses any other) and evaluates it as it trained. A field in ``own``
  that contradicts the checkpoint is left for ``train`` to refuse; one the checkpoint does not
  record (added to ``PPOConfig`` since) trained as every run before it did, where
  ``UNRECORDED_SETTINGS`` says how (``eval_actions``: the mean action), and else keeps
  ``config``'s value. A checkpoint without a config records nothing: ``config`` as it is."""
  recorded = meta.get("config") or {}
  if recorded:
    recorded = {**UNRECORDED_SETTINGS, **recorded}
  taken = {}
  for field in dataclasses.fields(PPOConfig):
    name, now = field.name, getattr(config, field.name)
    if name in own or name not in recorded:
      continue
    then = recorded[name]
    if name == "staggered_starts":  # recorded resolved; None chose by num_envs
      now = config.starts_staggered
    if _jsonable(then) != _jsonable(now):
      taken[name] = (tuple(then) if isinstance(now, tuple) else then, getattr(config, name))
  return config.replace(**{name: then for name, (then, _) in taken.items()}), taken


CHECKPOINT_SEGMENTS_ENV = "BLX_CHECKPOINT_SEGMENTS"


def segment_length(iterations_per_chunk: int, segments: int | None = None) -> int:
  """The iterations of one segment of a chunk cut into ``segments`` (``train``'s
  ``checkpoint_segments``; None: ``$BLX_CHECKPOINT_SEGMENTS``, else 1): ``ceil(iterations /
  segments)``, the last segment of a chunk taking what is left. Refuses a number that is not a
  whole number from 1 to the chunk's iterations, naming where it came from."""
  where = "checkpoint_segments"
  if segments is None:
    where = f"${CHECKPOINT_SEGMENTS_ENV}"
    setting = os.environ.get(CHECKPOINT_SEGMENTS_ENV, "").strip()
    # a setting that is not a whole number stays text, which the check below refuses
    segments = int(setting) if setting.isdecimal() else (setting or 1)
  if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) or not (
      1 <= segments <= iterations_per_chunk):
    raise ValueError(f"{where}={segments!r}: give a whole number of segments per chunk, 1 to "
                     f"{iterations_per_chunk} (this run's iterations per chunk)")
  return -(-iterations_per_chunk // int(segments))


def _segments(start_chunk: int, done: int, num_chunks: int, per_chunk: int, segment: int) -> list:
  """The segments left of a run, each ``(chunk, its first iteration in the chunk, iterations)``:
  each chunk cut at the multiples of ``segment``, from iteration ``done`` of ``start_chunk`` on
  (a resume mid-chunk, perhaps with another segment than it stopped with)."""
  out = []
  for chunk in range(start_chunk, num_chunks):
    first = done if chunk == start_chunk else 0
    while first < per_chunk:
      end = min(first - first % segment + segment, per_chunk)
      out.append((chunk, first, end - first))
      first = end
  return out


def _join(parts: list[dict]) -> dict:
  """Per-iteration metrics of consecutive segments (each ``[seeds, iterations]``), joined along
  the iterations."""
  return {k: np.concatenate([p[k] for p in parts], axis=1) for k in parts[0]}


def _metrics_to_json(metrics: dict) -> dict:
  return {k: {"dtype": str(v.dtype), "values": v.tolist()} for k, v in metrics.items()}


def _metrics_from_json(data: dict) -> dict:
  return {k: np.asarray(v["values"], dtype=v["dtype"]) for k, v in data.items()}


def _save(directory: str, state: TrainState, config: PPOConfig, meta: dict) -> None:
  """A checkpoint of ``state`` (without the envs' state where the config says so) and ``meta``,
  with the env steps the state has trained."""
  saved = state if config.checkpoint_env_state else state.replace(env_state=None)
  checkpoint.save(directory, saved, {**meta, "env_state": config.checkpoint_env_state,
                                     "env_steps": _env_steps(state)})


def _env_steps(state: TrainState) -> float:
  """The env steps per seed the vmapped ``state`` has trained (every seed's are the same)."""
  return float(np.asarray(state.env_steps)[0])


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
