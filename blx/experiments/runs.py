"""Run directories: what a training run writes, and how to rebuild everything from one.

A run directory holds:

* ``config.json``: everything needed to rebuild the run (format version, env name, params and the
  full desc, objective name and options, PPO config, seeds, evaluation settings); its PPO config
  names the settings the run sets itself, the rest being its env's row, and where blx's defaults
  moved since, the checkpoint's record of the settings it trained with wins (``_as_trained``);
* ``checkpoint/``: the training state of every seed (``blx.training.checkpoint``);
* ``metrics.csv``: one row per evaluation and seed, rewritten after every evaluation;
* ``eval.json``: the finished run's final metrics (written when training ends, or by ``blx eval``),
  with the machine that evaluated them and the env steps the parameters trained; never written
  for an unfinished run, as a sweep takes a point that has one as done;
* ``provenance.json``: where each process that trained the run ran (device, versions), over
  which env steps and with which PPO settings, every one (``read_provenance``), so that wall times
  are compared on like machines and reports name the settings a run trained with
  (``settings_as_trained``);
* ``plots/``: ``training_curves.png``, and ``skills.png`` (each skill's cloud in the feature space)
  and ``paths.png`` (where each skill takes the agent) for MI-max, or ``density.png`` and
  ``discriminator.png`` for D-min;
* ``video.mp4`` once rendered.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import platform
import sys
import time
from importlib import metadata
from typing import Any, NamedTuple, Sequence

import jax
import numpy as np

from blx import envs, metrics, objectives, training
from blx.experiments import plots
from blx.training import checkpoint
from blx.training.config import UNRECORDED_SETTINGS

__all__ = ["FORMAT_VERSION", "RunSpec", "Run", "RunError", "build", "load_run", "write_config",
           "write_metrics_csv", "default_obs_indices", "evaluator_for", "evaluate_run",
           "evaluate_run_keys", "summarise", "read_spec", "train_run", "evaluation", "write_eval",
           "Segment", "this_machine", "read_provenance", "settings_as_trained", "EVAL_PROTOCOLS",
           "check_eval_protocol", "check_time_settings"]

FORMAT_VERSION = 1
PROVENANCE = "provenance.json"
# The paper's metrics logged during training (``train_run(eval_metrics=True)``): "quick", fewer
# rollouts than the final evaluation (4 episodes for D-min; 4 skills x 4 episodes and 4 goals for
# MI-max), or "final", eval.json's own (10 of each). A policy that picks one of the target's modes
# per episode reads worse on 4 episodes than on 10 (RESULTS, session 32).
EVAL_PROTOCOLS = ("quick", "final")
# The LGR goals this blx's evaluators draw (``metrics.mimax_evaluator``'s default ``goal_draw``),
# recorded in every segment and in eval.json.
LGR_GOALS = metrics.LGR_GOAL_DRAWS[0]


class RunError(ValueError):
  """A run directory is missing, incomplete or from an incompatible version."""


@dataclasses.dataclass(frozen=True)
class RunSpec:
  """What defines a run; ``config.json`` is this, serialised."""

  env: str
  objective: str
  objective_options: dict
  ppo: dict
  seeds: tuple[int, ...] = (0,)
  env_params: dict = dataclasses.field(default_factory=dict)
  desc: dict | None = None
  # A multi-agent env: the agent the (reward-free) objective pays; the others keep their env rewards
  # (``objectives.for_agent``). None: the objective is the whole env's.
  agent: str | None = None


@dataclasses.dataclass(frozen=True)
class Segment:
  """One process's part of a run (``provenance.json`` holds one per start or resume): where it
  trained, and over which env steps per seed."""

  started: str            # when the process took the run up, UTC, ISO 8601
  # The run's env steps when the process took it up (0 for a new run) and at its last checkpoint:
  # within a chunk for a run trained in segments and stopped between evaluations. Segments
  # written before session 60 count both at evaluations (a process that stopped mid-chunk reads
  # as ending at its last evaluation, and the next as starting there).
  from_env_steps: float
  to_env_steps: float
  device: str             # jax's device kind, e.g. "NVIDIA H100 80GB HBM3" ("cpu" on a CPU)
  platform: str           # "gpu", "cpu" or "tpu"
  device_count: int       # the devices jax saw
  versions: dict          # python, jax, jaxlib, mujoco, mujoco-mjx and blx: version strings
  eval_protocol: str | None = None  # the metrics logged during training (EVAL_PROTOCOLS), if any
  # How this process drew the LGR goals it evaluated (``metrics.LGR_GOAL_DRAWS``): "braxlines", the
  # paper's goals, from session 41 on; None in segments written before, whose goals were
  # "partitionable" (other goals from the same key; RESULTS, session 41).
  lgr_goals: str | None = None
  # Every PPO setting this process trained with (``PPOConfig``'s fields, as JSON), the row's
  # included: config.json names only those the run sets itself. None in segments written before
  # session 60 (``settings_as_trained``).
  ppo: dict | None = None


def this_machine(from_env_steps: float = 0.0) -> Segment:
  """A ``Segment`` for this process, starting at ``from_env_steps``."""
  import mujoco

  import blx

  def version(dist: str) -> str | None:
    try:
      return metadata.version(dist)
    except metadata.PackageNotFoundError:
      return None

  devices = jax.devices()
  return Segment(
      started=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), from_env_steps=from_env_steps,
      to_env_steps=from_env_steps, device=devices[0].device_kind, platform=devices[0].platform,
      device_count=len(devices), lgr_goals=LGR_GOALS,
      versions={"python": platform.python_version(), "jax": jax.__version__,
                "jaxlib": version("jaxlib"), "mujoco": mujoco.__version__,
                "mujoco-mjx": version("mujoco-mjx"), "blx": blx.__version__})


def read_provenance(directory: str, filename: str = PROVENANCE) -> list[Segment]:
  """The segments of the run in ``directory``, in order; ``[]`` for a run trained before blx
  recorded them (session 31), whose machines only the notes beside it name. ``filename``: the
  file's name where a run's files were committed under a prefix (``cdiayn_provenance.json``)."""
  path = os.path.join(directory, filename)
  if not os.path.exists(path):
    return []
  names = {field.name for field in dataclasses.fields(Segment)}
  try:
    with open(path) as f:
      data = json.load(f)
    return [Segment(**{k: v for k, v in d.items() if k in names}) for d in data["segments"]]
  except (ValueError, KeyError, TypeError, AttributeError) as e:
    raise RunError(f"{path}: not a provenance file of blx ({e}); move it aside to go on with "
                   "the run without its record of machines") from None


def settings_as_trained(ppo: dict | None, segments: Sequence[Segment]) -> dict:
  """The PPO settings a run trained with, as far as its files tell (field -> value, as
  ``config.json``'s ``ppo`` holds them), for ``training.config.off_row`` to compare with its row:
  every setting, as its last segment recorded them (``Segment.ppo``), where it did; else its own
  (``ppo``, config.json's) over ``UNRECORDED_SETTINGS``, those that every run recording none took
  whatever blx's defaults are now. A report that labels a run by config.json alone would miss a
  setting it took from a default that has moved since."""
  for segment in reversed(segments):
    if segment.ppo is not None:
      return dict(segment.ppo)
  return {**UNRECORDED_SETTINGS, **(ppo or {})}


def _write_provenance(directory: str, segments: list[Segment]) -> None:
  _write_json(os.path.join(directory, PROVENANCE),
              {"segments": [dataclasses.asdict(s) for s in segments]})


def _write_json(path: str, data: Any, **dump) -> None:
  """Writes ``data`` to ``path`` as indented JSON, whole or not at all: a killed process leaves
  the file before the write (a temporary file, then ``os.replace``)."""
  with open(path + ".tmp", "w") as f:
    json.dump(data, f, indent=2, **dump)
  os.replace(path + ".tmp", path)


class Run(NamedTuple):
  """A run rebuilt from its directory (``load_run``): everything to evaluate, plot and render.

  ``params`` is a ``training.PolicyParams`` with a leading seed axis;
  ``policy(params_of_one_seed, obs, z=None)`` is the deterministic policy.
  """

  directory: str
  spec: RunSpec
  env: Any
  objective: objectives.Objective
  config: training.PPOConfig
  params: training.PolicyParams | None
  policy: Any
  meta: dict

  @property
  def env_steps(self) -> float | None:
    """The env steps per seed ``params`` had trained: the checkpoint's own count, which, for a
    run that trains in segments (``train(checkpoint_segments=...)``) and stopped mid-chunk, is past
    its last evaluation; else its last evaluation's (a checkpoint older than the count); None
    without a checkpoint."""
    return None if self.params is None else training.checkpoint_env_steps(self.meta)

  @property
  def finished(self) -> bool:
    """Whether ``params`` are the whole run's (``training.checkpoint_finished``); False without
    them."""
    return self.params is not None and training.checkpoint_finished(self.meta)


def default_obs_indices(env_name: str) -> str:
  """The feature space reward-free runs use by default: xy position for the point mass (it has no
  gait to speak of), xy velocity (the paper's "vel") for every body."""
  return "pos_xy" if env_name.split("_")[0] == "point" else "vel"


def build(spec: RunSpec):
  """``(env, objective, config)`` for a spec; errors name the bad choice and the valid ones."""
  if spec.env not in envs.list_envs() and spec.desc is None:
    raise ValueError(f"unknown env {spec.env!r}; valid envs are {envs.list_envs()}")
  if spec.desc is not None:
    # The episode is the env's: a run rebuilt from its desc keeps the length it was created with.
    episode = {k: spec.env_params[k] for k in ("episode_length", "action_repeat")
               if k in spec.env_params}
    if spec.env in envs.list_envs():
      episode.setdefault("episode_length", envs.registry.episode_length(spec.env))
    env = envs.create(desc=spec.desc, **episode)
  else:
    env = envs.create(spec.env, **spec.env_params)
  options = dict(spec.objective_options)
  accepted = objectives.options_of(spec.objective)  # also rejects an unknown objective
  agent = _check_agent(spec, env)
  if "obs_indices" in accepted:
    options.setdefault("obs_indices", default_obs_indices(spec.env) if agent is None
                       else _agent_obs_indices(spec, env))
  if "env" in accepted:
    options["env"] = env
  objective = objectives.make(spec.objective, **options)
  if agent is not None:
    objective = objectives.for_agent(objective, agent=agent,
                                     num_agents=envs.unwrap(env).num_agents)
  config = training.ppo_defaults(spec.env).replace(**spec.ppo)
  return env, objective, config


def _check_agent(spec: RunSpec, env) -> int | None:
  """The index of ``spec.agent`` in the env's agents, or None; errors name what is valid."""
  if spec.agent is None:
    return None
  names = list(envs.unwrap(env).agent_names)
  if not names:
    raise ValueError(f"agent {spec.agent!r}: {spec.env!r} is a single-agent env; leave the agent "
                     "out (the objective is the env's)")
  if spec.agent not in names:
    raise ValueError(f"agent {spec.agent!r}: {spec.env!r} has agents {names}")
  if spec.objective == "task":
    raise ValueError(f"agent {spec.agent!r} with objective 'task': every agent already gets its "
                     "own env reward; name a reward-free objective (e.g. diayn) to pay to one "
                     "agent")
  return names.index(spec.agent)


def _agent_obs_indices(spec: RunSpec, env) -> str:
  """The agent's own xy velocity (its component's): what reward-free objectives read by default."""
  name = f"{spec.agent}/vel_xy"
  if name not in env.named_indices:
    raise ValueError(f"agent {spec.agent!r}: no {name!r} in the observation; give the objective's "
                     "obs_indices (e.g. --obs-indices [i,j])")
  return name


def write_config(directory: str, spec: RunSpec, env) -> None:
  os.makedirs(directory, exist_ok=True)
  data = {"format_version": FORMAT_VERSION, "env": spec.env, "env_params": spec.env_params,
          "desc": env.desc, "objective": spec.objective,
          "objective_options": spec.objective_options,
          "ppo": spec.ppo, "seeds": list(spec.seeds), "agent": spec.agent}
  _write_json(os.path.join(directory, "config.json"), data, default=json_default)


def json_default(x):
  if isinstance(x, (np.ndarray, jax.Array)):
    return np.asarray(x).tolist()
  if isinstance(x, (np.integer, np.floating)):
    return x.item()
  raise TypeError(f"cannot write {type(x).__name__} to config.json")


def as_json(x):
  """``x`` as it reads back from config.json, for comparing settings with a run's (a value that
  config.json cannot hold compares by its text)."""
  def default(v):
    try:
      return json_default(v)
    except TypeError:
      return str(v)
  return json.loads(json.dumps(x, default=default))


def read_spec(directory: str) -> RunSpec:
  path = os.path.join(directory, "config.json")
  if not os.path.isdir(directory):
    raise RunError(f"no run directory at {directory!r}")
  if not os.path.exists(path):
    raise RunError(f"{directory!r} is not a blx run directory (no config.json)")
  try:
    with open(path) as f:
      data = json.load(f)
  except (OSError, json.JSONDecodeError) as e:
    raise RunError(f"{path}: unreadable config.json ({e})") from None
  if not isinstance(data, dict):
    raise RunError(f"{path}: expected a JSON object (a blx run config), got a "
                   f"{type(data).__name__}")
  version = data.get("format_version")
  if version != FORMAT_VERSION:
    raise RunError(f"{directory!r} was written by run format {version!r}; this blx reads format "
                   f"{FORMAT_VERSION}: retrain it with this version")
  try:
    ppo, env_params = dict(data["ppo"]), dict(data.get("env_params", {}))
    # Runs written while PPOConfig held the episode: it moves to the env's parameters.
    if ppo.get("eval_episode_length") is not None:
      raise RunError(f"{path}: written with eval_episode_length, which blx no longer has (the "
                     "env owns its episode); retrain it with this version")
    ppo.pop("eval_episode_length", None)
    for key in ("episode_length", "action_repeat"):
      if key in ppo:
        env_params.setdefault(key, ppo.pop(key))
    return RunSpec(env=data["env"], objective=data["objective"],
                   objective_options=data["objective_options"], ppo=ppo,
                   seeds=tuple(data["seeds"]), env_params=env_params, desc=data.get("desc"),
                   agent=data.get("agent"))
  except KeyError as e:
    raise RunError(f"{path}: missing key {e}") from None


def load_run(directory: str, *, need_checkpoint: bool = True) -> Run:
  """Rebuilds env, objective, config and the trained parameters from a run directory alone."""
  spec = read_spec(directory)
  env, objective, config = build(spec)
  ckpt = os.path.join(directory, "checkpoint")
  found = checkpoint.exists(ckpt)
  if found:  # the settings it trained with, read before the trainer they build
    try:
      config = _as_trained(directory, spec, config, checkpoint.read_meta(ckpt))
    except checkpoint.CheckpointError as e:  # damaged: it says so
      raise RunError(f"{ckpt}: {e}") from None
  trainer = training.make_trainer(env, objective, config)
  params, meta = None, {}
  if found:
    keys = jax.numpy.stack([jax.random.PRNGKey(s) for s in spec.seeds])
    like = jax.eval_shape(jax.vmap(trainer.init), keys)
    try:
      state, meta = training.restore_state(ckpt, like)
    except checkpoint.CheckpointError as e:  # damaged, or written by another config: it says which
      raise RunError(f"{ckpt}: {e}") from None
    except Exception as e:  # a checkpoint from another version
      raise RunError(f"{ckpt}: the checkpoint does not match config.json ({e})") from None
    params = training.policy_params(state)
  elif need_checkpoint:
    raise RunError(f"{directory!r} has no checkpoint yet (was training interrupted before the "
                   "first evaluation?)")
  return Run(directory, spec, env, objective, config, params, trainer.policy, meta)


def _as_trained(directory: str, spec: RunSpec, config: training.PPOConfig,
                meta: dict) -> training.PPOConfig:
  """``config`` as the run in ``directory`` trained with it, by its checkpoint's metadata ``meta``
  (``training.config_as_trained``): where blx's defaults moved since the checkpoint was written, a
  setting its config.json leaves to them keeps the checkpoint's value, and a line on stderr names
  each, so that a resume goes on and an evaluation scores the run as it trained."""
  config, taken = training.config_as_trained(meta, config, own=spec.ppo)
  if taken:
    kept = ", ".join(f"{name} {then!r} (blx's default now {now!r})"
                     for name, (then, now) in taken.items())
    print(f"[blx] {directory} keeps the settings it trained with where blx's defaults moved "
          f"since: {kept}", file=sys.stderr)
  return config


def write_metrics_csv(path: str, history: list[dict], seeds) -> None:
  """One row per evaluation and seed; scalar columns only."""
  rows = []
  for row in history:
    for i, seed in enumerate(seeds):
      out = {"seed": seed}
      for k, v in row.items():
        if isinstance(v, list):
          if i < len(v) and not isinstance(v[i], list):
            out[k] = v[i]
        elif isinstance(v, (int, float)):
          out[k] = v
      rows.append(out)
  columns = list(dict.fromkeys(k for r in rows for k in r))
  tmp = path + ".tmp"
  with open(tmp, "w", newline="") as f:
    writer = csv.DictWriter(f, columns)
    writer.writeheader()
    writer.writerows(rows)
  os.replace(tmp, path)


def evaluator_for(env, objective, *, quick: bool = False):
  """The paper's evaluator for the objective (``blx.metrics.evaluator_for``) on the run's env and
  its episodes; None for objectives measured by their rewards alone."""
  return metrics.evaluator_for(env, objective, quick=quick)


def check_eval_protocol(directory: str, eval_metrics: bool, eval_protocol: str | None,
                        segments: Sequence[Segment] = ()) -> str:
  """The protocol a run logs its curves with: ``eval_protocol``, or where it is None the run's
  own (the last one ``segments`` record), else "quick". Refuses a protocol blx does not know, one
  asked without metrics to log, and a resume that would log its curves with another protocol than
  the run's so far (one curve, two estimators)."""
  logged = [s.eval_protocol for s in segments if s.eval_protocol is not None]
  if eval_protocol is None:
    return logged[-1] if eval_metrics and logged else "quick"
  if eval_protocol not in EVAL_PROTOCOLS:
    raise RunError(f"eval_protocol {eval_protocol!r}: valid are {', '.join(EVAL_PROTOCOLS)}")
  if eval_protocol != "quick" and not eval_metrics:
    raise RunError(f"eval_protocol {eval_protocol!r} sets how the metrics logged during training "
                   "are evaluated, and none are logged: add --eval-metrics (eval_metrics=True)")
  if eval_metrics and logged and logged[-1] != eval_protocol:
    raise RunError(f"{directory!r} logged its metrics during training with the {logged[-1]!r} "
                   f"protocol ({PROVENANCE}); resume it with --eval-protocol {logged[-1]}, or "
                   "without the flag, so that one curve has one estimator, or train a new run")
  return eval_protocol


def evaluate_run(run: Run, *, key_seed: int = 0) -> dict[str, list[float]]:
  """The final metrics of every seed: MI-max -> MI, H(s), LGR, coverage; D-min -> energy
  distance; always the episode reward and score of the trainer's return episodes (mean or sampled
  actions, as ``run.config.eval_actions``). ``key_seed`` seeds the evaluation's own sampling (its
  episodes' starts, sampled actions, goals); eval.json's is 0."""
  return evaluate_run_keys(run, (key_seed,))[0]


def evaluate_run_keys(run: Run, key_seeds: Sequence[int], *, metrics_only: bool = False,
                      protocol: str = "final") -> list[dict[str, list[float]]]:
  """:func:`evaluate_run` once per evaluation key seed in ``key_seeds``, compiled once: how much
  of a final number is the evaluation's own sampling rather than the policy (e.g. a policy that
  picks one of the target's modes per episode, scored on 10 episodes). ``metrics_only`` keeps the
  objective's evaluator alone (the same values under the same keys), without the trainer's
  ``num_eval_envs`` return episodes per seed, most of an evaluation's cost on a CPU; it needs an
  objective with an evaluator. ``protocol`` (``EVAL_PROTOCOLS``) sizes the paper's evaluator:
  "final", eval.json's, or "quick", that of the curves ``--eval-metrics`` logs during training, so
  that a checkpoint can be read both ways under the same keys."""
  if protocol not in EVAL_PROTOCOLS:
    raise ValueError(f"protocol {protocol!r}: valid are {', '.join(EVAL_PROTOCOLS)}")
  trainer = training.make_trainer(run.env, run.objective, run.config)
  evaluator = evaluator_for(run.env, run.objective, quick=protocol == "quick")
  if metrics_only and evaluator is None:
    raise ValueError(f"metrics_only (blx eval --metrics-only): objective {run.objective.name!r} "
                     "has no evaluator, so its only metrics are the returns this leaves out; "
                     "evaluate it without metrics_only")

  def one(params, key):
    out = {}
    if not metrics_only:
      kept = training.RETURN_KEYS
      out = {k: v for k, v in trainer.evaluate(params, key).items()  # with per-agent totals
             if k in kept or (k.count("/") == 2 and k.rsplit("/", 1)[0] in kept)}
    if evaluator is not None:
      out.update(evaluator(trainer.policy, params, key))
    return out

  evaluate = jax.jit(jax.vmap(one))
  results = []
  for key_seed in key_seeds:
    keys = jax.random.split(jax.random.PRNGKey(key_seed), len(run.spec.seeds))
    values = evaluate(run.params, keys)
    results.append({k: [float(x) for x in np.asarray(v)] for k, v in values.items()})
  return results


def summarise(values: dict[str, list[float]]) -> dict[str, dict[str, float]]:
  """mean and std (population, as numpy) over seeds of every metric."""
  return {k: {"mean": float(np.mean(v)), "std": float(np.std(v)), "n": len(v)}
          for k, v in values.items()}


def check_time_settings(spec: RunSpec, directory: str, *, resume: bool,
                        built: tuple | None = None) -> float | None:
  """Refuses a bad ``$BLX_STOP_BY`` or ``$BLX_CHECKPOINT_SEGMENTS`` (``training.stop_time``,
  ``training.segment_length``) for the run ``train_run(spec, directory, resume=resume)`` would
  train, with the settings it trains with (a resume's own), before anything is written; returns
  the time limit (``training.stop_time()``). ``train_run`` checks them itself; a caller that
  writes or says something first (a sweep's folder, ``blx train``'s line naming the run) calls
  this before it. ``built``: ``build(spec)``, where the caller has it."""
  env, _, config = built if built is not None else build(spec)
  stop_by = training.stop_time()
  ckpt = os.path.join(directory, "checkpoint")
  if resume and checkpoint.exists(ckpt):
    config, _ = training.config_as_trained(checkpoint.read_meta(ckpt), config, own=spec.ppo)
  training.segment_length(training.run_chunks(config, getattr(env, "action_repeat", 1))[1])
  return stop_by


def train_run(spec: RunSpec, directory: str, *, resume: bool = False, progress=True,
              eval_metrics: bool = False, eval_protocol: str | None = None) -> Run:
  """Trains ``spec`` into ``directory`` and completes it: config, checkpoint, metrics.csv, then
  ``eval.json`` and the plots. ``run.meta`` holds ``history``, ``eval`` and ``plots`` (paths).

  ``eval_metrics`` also logs the paper's metrics (MI, energy distance, ...) at every evaluation
  during training, with ``eval_protocol``'s rollouts (``EVAL_PROTOCOLS``: "quick" or "final",
  eval.json's), recorded in ``provenance.json``. None, the default, is the run's own protocol when
  it is resumed, else "quick"; another than the run's own is refused.

  An existing run directory is only continued with ``resume=True``; it is never overwritten.
  """
  env, objective, config = build(spec)
  # $BLX_STOP_BY and $BLX_CHECKPOINT_SEGMENTS, refused before a directory is made or a resume
  # is recorded
  stop_by = check_time_settings(spec, directory, resume=resume, built=(env, objective, config))
  exists = os.path.exists(os.path.join(directory, "config.json"))
  if exists and not resume:
    raise RunError(f"{directory!r} already holds a run; pass --resume to continue it or choose "
                   "another --out")
  if resume and not exists:
    raise RunError(f"nothing to resume: {directory!r} is not a blx run directory (no config.json)")
  if not exists and os.path.exists(os.path.join(directory, "checkpoint")):
    raise RunError(f"{directory!r} holds a checkpoint but no config.json; it is not overwritten: "
                   "choose another --out")
  if exists:
    old = read_spec(directory)
    if (old.env, old.objective, list(old.seeds)) != (spec.env, spec.objective, list(spec.seeds)):
      raise RunError(f"{directory!r} holds a run of {old.objective} on {old.env} with seeds "
                     f"{list(old.seeds)}; resume it with the same settings")
  checkpoint_dir = os.path.join(directory, "checkpoint")
  # the checkpoint a resume goes on from: the settings it trained with and its evaluations so far
  resumed = (checkpoint.read_meta(checkpoint_dir) if resume and checkpoint.exists(checkpoint_dir)
             else {})
  if resumed:
    config = _as_trained(directory, spec, config, resumed)
  segments = read_provenance(directory) if exists else []
  eval_protocol = check_eval_protocol(directory, eval_metrics, eval_protocol, segments)
  if not exists:  # a resumed run keeps its config.json untouched
    write_config(directory, spec, env)
  evaluator = (evaluator_for(env, objective, quick=eval_protocol == "quick") if eval_metrics
               else None)
  # metrics.csv grows with every evaluation, so that a run stopped before its end (a killed
  # process, a lost machine) still shows its curves up to its last checkpoint.
  history = list(resumed.get("history", []))
  show = training.print_progress if progress is True else (progress or None)
  # from the steps the checkpoint holds, past its last evaluation where it stopped mid-chunk
  start = training.checkpoint_env_steps(resumed) or 0.0
  segments.append(dataclasses.replace(
      this_machine(start), eval_protocol=eval_protocol if eval_metrics else None,
      ppo=dataclasses.asdict(config)))
  _write_provenance(directory, segments)

  def report(row: dict) -> None:
    history.append(row)
    write_metrics_csv(os.path.join(directory, "metrics.csv"), history, spec.seeds)
    segments[-1] = dataclasses.replace(segments[-1], to_env_steps=float(row["env_steps"]))
    _write_provenance(directory, segments)
    if show:
      show(row)

  # A progress that reports rows can show segments too: True, print_segment's line; an object,
  # its `segment` method where it has one (the command line's progress bar).
  show_segment = training.print_segment if progress is True else getattr(show, "segment", None)

  def segment_done(done: training.SegmentDone) -> None:
    # provenance.json names the steps the last checkpoint holds, also for a process killed
    # without a word (no exception, so no _to_last_checkpoint) before the chunk's evaluation
    if done.checkpoint_dir:
      segments[-1] = dataclasses.replace(segments[-1], to_env_steps=done.env_steps)
      _write_provenance(directory, segments)
    if show_segment:
      show_segment(done)

  try:
    result = training.train(env, objective, config, seeds=spec.seeds, progress=report,
                            checkpoint_dir=checkpoint_dir, resume=resume, evaluate=evaluator,
                            on_segment=segment_done, stop_by=stop_by)
  except BaseException:  # stopped (Ctrl-C, a device call's limit) or failed: the steps it kept
    _to_last_checkpoint(directory, checkpoint_dir, segments)
    raise
  write_metrics_csv(os.path.join(directory, "metrics.csv"), result.metrics, spec.seeds)
  run = Run(directory, spec, env, objective, config, result.params, result.policy,
            {"history": result.metrics})
  run.meta["eval"] = write_eval(run)
  run.meta["plots"] = plots.write_all(run, result.metrics,
                                      lgr_goals_from=lgr_goals_switch(segments))
  return run


def _to_last_checkpoint(directory: str, checkpoint_dir: str, segments: list[Segment]) -> None:
  """Ends this process's segment (the last) at the env steps of the run's last checkpoint where
  it wrote one after its last evaluation (a chunk trained in segments, stopped between
  evaluations), so that provenance.json counts the steps it kept; a checkpoint it cannot read,
  or a record it cannot write, leaves the segment as it is (the error that stopped the process is
  the one raised)."""
  try:
    steps = (training.checkpoint_env_steps(checkpoint.read_meta(checkpoint_dir))
             if checkpoint.exists(checkpoint_dir) else None)
    if steps is not None and steps > segments[-1].to_env_steps:
      segments[-1] = dataclasses.replace(segments[-1], to_env_steps=steps)
      _write_provenance(directory, segments)
  except (checkpoint.CheckpointError, OSError):
    return


def segment_at(segments: list[Segment] | tuple, env_steps: float) -> Segment | None:
  """The segment whose process logged the evaluation at ``env_steps`` (``from_env_steps <
  env_steps <= to_env_steps``); None where none did (steps trained before blx recorded
  provenance, or no provenance)."""
  for segment in segments:
    if segment.from_env_steps < env_steps <= segment.to_env_steps:
      return segment
  return None


def lgr_goals_switch(segments: list[Segment]) -> float | None:
  """The env steps after which a run's evaluations scored the LGR on the paper's goals where its
  earlier ones did not (a run begun before session 41, or before blx recorded provenance, and
  resumed after); None where its goals never changed."""
  if segments and segments[0].lgr_goals == "braxlines" and segments[0].from_env_steps > 0:
    return segments[0].from_env_steps  # the steps before it: no record, so the old goals
  for before, segment in zip(segments, segments[1:]):
    if segment.lgr_goals == "braxlines" and before.lgr_goals != "braxlines":
      return before.to_env_steps
  return None


def evaluation(run: Run) -> dict:
  """Every seed evaluated, as ``eval.json`` holds it (per seed and mean/std), not written.

  ``evaluated_on`` records the machine that evaluated (when, device, versions), which need not be
  the one that trained: a run's final evaluation can be taken up on another machine by ``blx
  eval``, and the episodes' physics differ in their last bits between CPU and GPU.
  ``env_steps`` is how far the evaluated parameters had trained (``Run.env_steps``): an unfinished
  run's last checkpoint's, perhaps mid-chunk."""
  values = evaluate_run(run)
  machine = this_machine()
  return {"per_seed": values, "summary": summarise(values), "seeds": list(run.spec.seeds),
          "objective": run.spec.objective, "env": run.spec.env, "env_steps": run.env_steps,
          "evaluated_on": {"date": machine.started, "device": machine.device,
                           "platform": machine.platform, "device_count": machine.device_count,
                           "versions": machine.versions, "lgr_goals": machine.lgr_goals}}


def write_eval(run: Run) -> dict:
  """``evaluation(run)``, written to ``eval.json`` and returned. Refused for an unfinished run:
  eval.json is the finished run's final evaluation, and a sweep takes a point that has one as
  done (``evaluation`` scores an unfinished run without writing it)."""
  if not run.finished:
    raise RunError(f"{run.directory!r} is unfinished ({training.checkpoint_progress(run.meta)}): "
                   "eval.json is written once its training ends; evaluation(run) scores it as it "
                   "stands")
  out = evaluation(run)
  _write_json(os.path.join(run.directory, "eval.json"), out)
  return out
