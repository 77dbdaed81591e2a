"""The ``blx`` command: ``envs``, ``train``, ``eval``, ``render``, ``sweep``.

Set ``BLX_DEBUG=1`` to see the traceback behind an error line.

Bad input (an unknown env, objective or key, a malformed ``--config``, a missing or incompatible run
directory) prints one line naming the problem and the valid choices, and exits with status 2.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import json
import os
import sys
import time

__all__ = ["main", "run_main", "INTERRUPTED_STATUS"]

DEFAULT_ENV, DEFAULT_OBJECTIVE = "point", "diayn"
INTERRUPTED_STATUS = 130  # a shell's status for a program ended by Ctrl-C (128 + SIGINT)
ENVIRONMENT = """environment variables:
  BLX_COMPILATION_CACHE  where compiled programs are kept between runs (default
                         ~/.cache/blx/jax); "off" turns the cache off
  MUJOCO_GL              OpenGL backend for `blx render`: egl (default), osmesa, glfw, glx;
                         the other commands need no OpenGL
  BLX_DEBUG=1            show the traceback behind an error line"""


class UsageError(Exception):
  """Bad input from the command line: one line, exit status 2."""


# JSON's spellings, which users type as often as Python's (--config staggered_starts=true).
_WORDS = {"true": True, "false": False, "null": None}


def _parse_value(text: str):
  """A Python literal (``1e-3``, ``True``, ``[13, 14]``), JSON's ``true`` / ``false`` / ``null`` in
  any case, or else the text itself (a bare word such as ``vel_xy``)."""
  if text.lower() in _WORDS:
    return _WORDS[text.lower()]
  try:
    return ast.literal_eval(text)
  except (ValueError, SyntaxError):
    return text


def _parse_pairs(items, flag: str) -> dict:
  out = {}
  for item in items or []:
    key, sep, value = item.partition("=")
    if not sep or not key:
      raise UsageError(f"{flag} {item!r}: expected key=value, e.g. {flag} learning_rate=1e-3")
    out[key.strip()] = _parse_value(value.strip())
  return out


def _parse_seeds(text: str) -> tuple[int, ...]:
  try:
    seeds = tuple(int(s) for s in text.split(",") if s.strip())
  except ValueError:
    raise UsageError(f"--seeds {text!r}: expected comma-separated ints, e.g. --seeds 0,1,2") from None
  from blx.training.config import check_seeds
  try:
    return check_seeds(seeds, f"--seeds {text!r}")
  except ValueError as e:
    raise UsageError(str(e)) from None


class _Progress:
  """A live progress line: steps, steps/s, ETA and the latest evaluation metrics."""

  KEYS = ("eval/episode_reward", "disc/accuracy", "eval/mi", "eval/lgr", "eval/energy_distance")

  def __init__(self, stream=sys.stderr):
    self.stream = stream
    self.tty = stream.isatty()

  def __call__(self, row: dict) -> None:
    import numpy as np
    evals = "  ".join(f"{k.split('/', 1)[1]} {np.mean(row[k]):.3g}" for k in self.KEYS if k in row)
    self._write(row["env_steps"], row["total_steps"], row["steps_per_second"],
                row["eta_seconds"], evals)

  def segment(self, done) -> None:
    """A segment within a chunk (``BLX_CHECKPOINT_SEGMENTS``): where the run stands, whether it
    was checkpointed; the metrics come with the chunk's evaluation."""
    self._write(done.env_steps, done.total_steps, done.steps_per_second, done.eta_seconds,
                f"({done.where()})")

  def _write(self, steps: float, total: float, rate: float, eta: float, tail: str) -> None:
    frac = steps / max(total, 1)
    bar = "#" * int(24 * frac) + "." * (24 - int(24 * frac))
    line = f"[{bar}] {steps:,.0f}/{total:,.0f} steps  {rate:,.0f}/s  ETA {eta:.0f}s  {tail}"
    end = "\n" if (not self.tty or frac >= 1) else ""
    self.stream.write(("\r\x1b[2K" if self.tty else "") + line + end)
    self.stream.flush()


# ------------------------------------------------------------------------------------------------


def cmd_envs(args) -> int:
  from blx import envs
  if not args.name:
    print("envs:       " + ", ".join(envs.list_envs()))
    print("components: " + ", ".join(envs.list_components()))
    return 0
  if args.name not in envs.list_envs():
    raise UsageError(f"unknown env {args.name!r}; valid envs are {envs.list_envs()}")
  env = envs.create(args.name)
  print(f"{args.name}: observation size {env.observation_size}, action size {env.action_size}")
  print("observation layout:")
  for name, sl in env.obs_layout.items():
    print(f"  [{sl.start:3d}:{sl.stop:3d}]  {name}")
  print("reward terms: " + (", ".join(env.reward_terms) or "(none)"))
  base = envs.unwrap(env)
  if base.agents:
    print("agents (MAPPO: one policy each; reward is a vector in this order):")
    for i, agent in enumerate(base.agent_names):
      terms = [t for t, k in zip(base.reward_terms, base.agents.term_agent) if k == i]
      print(f"  {agent}: actions {base.agent_action_indices[agent].tolist()}, "
            f"rewards {', '.join(terms) or '(none)'}")
  print("named indices (for --obs-indices):")
  for name, idx in env.named_indices.items():
    if "/" not in name:
      print(f"  {name:10s} {list(idx)}")
  params = envs.env_params(args.name)
  if params:
    print("env params: " + ", ".join(f"{k}={v!r}" for k, v in params.items()))
  length = envs.registry.episode_length(args.name)
  print(f"episode: {length} steps, action repeat 1 (the env's own: --env-param episode_length=N, "
        "--env-param action_repeat=N)")
  return 0


def _given(args) -> dict:
  """The run settings given on the command line, by what they set: ``env``, ``objective``,
  ``seeds``, ``option:NAME``, ``config:NAME``, ``env_param:NAME``."""
  given = {}
  if args.env is not None:
    given["env"] = args.env
  if args.objective is not None:
    given["objective"] = args.objective
  if args.seeds is not None:
    given["seeds"] = list(_parse_seeds(args.seeds))
  if args.agent is not None:
    given["agent"] = args.agent
  options = _parse_pairs(args.option, "--option")
  if args.num_skills is not None:
    options["num_skills"] = args.num_skills
  if args.obs_indices is not None:
    options["obs_indices"] = _parse_value(args.obs_indices)
  ppo = _parse_pairs(args.config, "--config")
  if args.steps is not None:
    ppo["num_timesteps"] = args.steps
  given.update({f"option:{k}": v for k, v in options.items()})
  given.update({f"config:{k}": v for k, v in ppo.items()})
  given.update({f"env_param:{k}": v for k, v in _parse_pairs(args.env_param, "--env-param").items()})
  return given


def _spec_from_args(args):
  from blx.experiments import runs
  given = _given(args)
  env = given.get("env", DEFAULT_ENV)
  objective = given.get("objective", DEFAULT_OBJECTIVE)
  pick = lambda group: {k.split(":", 1)[1]: v for k, v in given.items() if k.startswith(group)}
  options = pick("option:")
  return runs.RunSpec(env=env, objective=objective, objective_options=options,
                      ppo=pick("config:"), seeds=tuple(given.get("seeds", (0,))),
                      env_params=pick("env_param:"), agent=given.get("agent"))


def _resume_spec(args, directory: str):
  """The run's own spec; every setting also given on the command line must agree with it."""
  from blx.experiments import runs
  spec = runs.read_spec(directory)
  have = {"env": spec.env, "objective": spec.objective, "seeds": list(spec.seeds),
          **({"agent": spec.agent} if spec.agent is not None else {}),
          **{f"option:{k}": v for k, v in spec.objective_options.items()},
          **{f"config:{k}": v for k, v in spec.ppo.items()},
          **{f"env_param:{k}": v for k, v in spec.env_params.items()}}
  flag = {"option": "--option", "config": "--config", "env_param": "--env-param"}
  for key, value in _given(args).items():
    if key not in have or runs.as_json(have[key]) != runs.as_json(value):
      group, _, name = key.partition(":")
      shown = f"{flag[group]} {name}={value!r}" if name else f"--{key} {value!r}"
      was = f"{have[key]!r}" if key in have else "not set"
      raise UsageError(f"--resume {directory}: {shown} contradicts the run, where it is {was}; "
                       "leave the flag out to continue the run as it was")
  return spec


def cmd_train(args) -> int:
  from blx.experiments import runs
  resume = args.resume is not None
  if resume:
    out = args.resume or args.out
    if not out:
      raise UsageError("--resume: name the run directory (blx train --resume DIR)")
    if args.resume and args.out and os.path.abspath(args.out) != os.path.abspath(args.resume):
      raise UsageError(f"--resume {args.resume} and --out {args.out} name different directories")
    spec = _resume_spec(args, out)
  else:
    spec = _spec_from_args(args)
    out = args.out or os.path.join(
        "runs", f"{spec.env}_{spec.objective}_{time.strftime('%Y%m%d-%H%M%S')}")
  # everything validated ($BLX_STOP_BY and $BLX_CHECKPOINT_SEGMENTS too) before a directory is
  # made or the run named
  runs.check_time_settings(spec, out, resume=resume)
  print(f"[blx] training {spec.objective} on {spec.env}, seeds {list(spec.seeds)} -> {out}",
        file=sys.stderr)
  try:
    run = runs.train_run(spec, out, resume=resume, progress=_Progress(),
                         eval_metrics=args.eval_metrics, eval_protocol=args.eval_protocol)
  except KeyboardInterrupt:
    print(f"[blx] interrupted: continue with  blx train --resume {out}", file=sys.stderr)
    return INTERRUPTED_STATUS
  _print_summary(run.meta["eval"]["summary"])
  print(f"[blx] run directory: {out} (config.json, metrics.csv, eval.json, checkpoint/, "
        + ", ".join(os.path.relpath(p, out) for p in run.meta["plots"]) + ")", file=sys.stderr)
  return 0


def _print_summary(summary: dict) -> None:
  width = max((len(k) for k in summary), default=10)
  for key, s in summary.items():
    print(f"{key:{width}s}  {s['mean']:10.4f} ± {s['std']:.4f}  (n={s['n']})")


def cmd_eval(args) -> int:
  from blx import training
  from blx.experiments import runs
  # the keys are checked before the run is loaded and compiled
  key_seeds = None if args.key_seeds is None else _key_seeds(args.key_seeds)
  if args.metrics_only and key_seeds is None:
    raise UsageError("--metrics-only applies with --key-seeds: eval.json always holds every "
                     "metric")
  if args.eval_protocol is not None and key_seeds is None:
    raise UsageError("--eval-protocol applies with --key-seeds: eval.json is always the final "
                     "protocol's")
  protocol = _eval_protocol(args.eval_protocol)
  actions = _eval_actions(args.eval_actions)
  run = runs.load_run(args.dir)
  own = run.config.eval_actions
  # another way of acting than the run's own: evaluated and reported, eval.json kept as the run's
  other = actions not in (None, own)
  if other:
    run = run._replace(config=run.config.replace(eval_actions=actions))
  # an unfinished run's parameters are its last checkpoint's, which may stand within a chunk,
  # past the last evaluation in its metrics.csv: every way of evaluating it says so
  standing = ("" if run.finished else f"{args.dir} is unfinished "
              f"({training.checkpoint_progress(run.meta)}): evaluated as it stands")
  also = f"; {standing}" if standing else ""
  if key_seeds is None and not other and run.finished:
    result = runs.write_eval(run)
  elif key_seeds is None and not other:
    result = runs.evaluation(run)
    print(f"[blx] {standing}; eval.json, the final evaluation, is written when its training ends",
          file=sys.stderr)
  elif key_seeds is None:
    result = {**runs.evaluation(run), "eval_actions": actions}
    print(f"[blx] evaluated with eval_actions={actions!r}; eval.json (the run's own, "
          f"{own!r}) is left as it was{also}", file=sys.stderr)
  else:
    result = {**across_keys(key_seeds, runs.evaluate_run_keys(
        run, key_seeds, metrics_only=args.metrics_only, protocol=protocol)),
              "env_steps": run.env_steps, "eval_protocol": protocol}
    print(f"[blx] evaluated with evaluation keys {key_seeds}"
          + (f" and eval_actions={actions!r}" if other else "")
          + (", the quick protocol's sizes (the curves')" if protocol == "quick" else "")
          + f"; eval.json (key 0) is left as it was{also}", file=sys.stderr)
  # how far the evaluated parameters had trained: an unfinished run's last checkpoint's
  trained = "" if run.env_steps is None else f", trained {run.env_steps:,.0f} env steps per seed"
  if args.json:
    print(json.dumps(result, indent=2))
  elif key_seeds is None:
    print(f"{run.spec.objective} on {run.spec.env}, seeds {list(run.spec.seeds)}{trained}"
          + (f", eval_actions={actions!r}" if other else ""))
    _print_summary(result["summary"])
  else:
    print(f"{run.spec.objective} on {run.spec.env}, seeds {list(run.spec.seeds)}{trained}: the "
          f"mean over seeds per evaluation key {key_seeds}; the std of that mean across keys; the "
          "mean over seeds of each seed's std across keys (the evaluation's own noise)")
    width = max((len(k) for k in result["across_keys"]), default=10)
    for key, s in result["across_keys"].items():
      means = "  ".join(f"{m:.4f}" for m in s["mean_per_key"])
      print(f"{key:{width}s}  {means}   ± {s['std_of_mean']:.4f}   per seed ± "
            f"{s['seed_std']:.4f}")
  return 0


def _eval_protocol(text: str | None) -> str:
  """``blx eval --eval-protocol``: "final" where not given, else one of ``EVAL_PROTOCOLS``,
  checked before the run is loaded and compiled."""
  from blx.experiments.runs import EVAL_PROTOCOLS
  if text is not None and text not in EVAL_PROTOCOLS:
    raise UsageError(f"--eval-protocol {text!r}: give one of {', '.join(EVAL_PROTOCOLS)} (quick: "
                     "the sizes of the curves logged during training; final: eval.json's)")
  return text or "final"


def _eval_actions(text: str | None) -> str | None:
  """``blx eval --eval-actions``: None (the run's own), or one of ``PPOConfig.eval_actions``'s
  values, checked before the run is loaded and compiled."""
  from blx.training.config import EVAL_ACTIONS
  if text is not None and text not in EVAL_ACTIONS:
    raise UsageError(f"--eval-actions {text!r}: give one of {', '.join(EVAL_ACTIONS)} (sampled "
                     "actions, blx's default, as Braxlines' PPO evaluates, or the mean action)")
  return text


def _key_seeds(text: str) -> list[int]:
  try:
    seeds = [int(s) for s in text.split(",")]
  except ValueError:
    seeds = []
  if not seeds or min(seeds) < 0 or max(seeds) >= 2**31 or len(set(seeds)) < len(seeds):
    raise UsageError(f"--key-seeds {text!r}: give distinct ints in 0..2**31 - 1 separated by "
                     "commas, e.g. --key-seeds 0,1,2 (0 is eval.json's key)")
  return seeds


def across_keys(key_seeds: list[int], per_key: list[dict[str, list[float]]]) -> dict:
  """A run evaluated once per evaluation key (``runs.evaluate_run_keys``): per key, the values
  per seed and their summary; per metric, the mean over seeds per key, the std of that mean
  across keys, and the mean over seeds of each seed's std across keys (population stds, as
  ``runs.summarise``): how far the final number moves with the evaluation's own sampling."""
  import numpy as np
  from blx.experiments import runs
  table = {}
  for metric in per_key[0]:
    values = np.asarray([v[metric] for v in per_key])  # [keys, seeds]
    table[metric] = {"mean_per_key": values.mean(axis=1).tolist(),
                     "std_of_mean": float(values.mean(axis=1).std()),
                     "seed_std": float(values.std(axis=0).mean())}
  return {"key_seeds": key_seeds,
          "per_key": [{"per_seed": v, "summary": runs.summarise(v)} for v in per_key],
          "across_keys": table}


MAX_FRAME = 4096  # pixels per side


def _check_render_args(args) -> None:
  """Rejects render options that would fail late or write something else than asked."""
  for flag, value in (("--width", args.width), ("--height", args.height)):
    if not 16 <= value <= MAX_FRAME:
      raise UsageError(f"{flag} {value}: valid sizes are 16..{MAX_FRAME} pixels")
  if args.steps is not None and args.steps < 1:
    raise UsageError(f"--steps {args.steps}: give at least 1 env step (or leave it out for the "
                     "whole episode)")
  if args.out is not None and not args.out.lower().endswith(".mp4"):
    raise UsageError(f"--out {args.out!r}: blx render writes MP4 video; give a path ending in .mp4")
  if args.skills:
    try:
      [int(s) for s in args.skills.split(",")]
    except ValueError:
      raise UsageError(f"--skills {args.skills!r}: expected comma-separated skill numbers, e.g. "
                       "--skills 0,3") from None


def cmd_render(args) -> int:
  import jax
  import jax.numpy as jnp
  import numpy as np
  from blx import envs, metrics
  from blx.experiments import render, runs  # render.render_frames loads the GL backend
  _check_render_args(args)
  run = runs.load_run(args.dir)
  if not 0 <= args.seed_index < len(run.spec.seeds):
    raise UsageError(f"--seed-index {args.seed_index}: the run has {len(run.spec.seeds)} seed(s)")
  params = jax.tree.map(lambda x: x[args.seed_index], run.params)
  key = jax.random.PRNGKey(0)
  prior = getattr(run.objective.spec, "prior", None)
  if prior is not None:  # skills to choose from
    latents = metrics.latents_for_evaluation(run.objective, key, 4)
    chosen = list(range(latents.shape[0]))
    if args.skills:
      chosen = [int(s) for s in args.skills.split(",")]
      bad = [s for s in chosen if not 0 <= s < latents.shape[0]]
      if bad:
        raise UsageError(f"--skills {bad}: valid skills are 0..{latents.shape[0] - 1}")
    latents = latents[np.asarray(chosen)]
    if prior.kind == "categorical":
      labels = [f"{run.spec.objective}: skill {k}" for k in chosen]
    else:
      labels = [f"{run.spec.objective}: z = ({', '.join(f'{v:+.2f}' for v in np.asarray(z))})"
                for z in latents]
  else:
    if args.skills:
      raise UsageError(f"--skills: {run.spec.objective} has no skills")
    latents = jnp.zeros((1, run.objective.latent_size))
    labels = [f"{run.spec.objective} on {run.spec.env}"]
  repeat = getattr(run.env, "action_repeat", 1)
  length = envs.episode_steps(run.env, "render") * repeat
  steps = min(args.steps or length, length) // repeat
  qpos = np.asarray(render.rollout_qpos(run, params, latents, key, steps=steps))
  model, base = run.env.mj_model, envs.unwrap(run.env)
  if base.agents:  # each agent its own colour, named in the label
    model, legend = render.colour_agents(model, base.agent_names)
    labels = [f"{label}\n{legend}" for label in labels]
  frames = np.concatenate([
      render.label_frames(render.render_frames(model, q, width=args.width,
                                               height=args.height,
                                               track=base.tracked_bodies), label)
      for q, label in zip(qpos, labels)])
  out = args.out or os.path.join(args.dir, "video.mp4")
  fps = 1.0 / (run.env.dt * repeat)
  render.write_video(out, frames, fps=min(fps, 60.0))
  print(f"[blx] wrote {out}: {len(frames)} frames of {args.width}x{args.height}, "
        f"{latents.shape[0]} episode(s)", file=sys.stderr)
  return 0


def cmd_sweep(args) -> int:
  from blx.experiments import sweep
  spec = sweep.load_spec(args.spec)
  out = args.out or spec.get("out") or os.path.join(
      "sweeps", spec.get("name") or os.path.splitext(os.path.basename(args.spec))[0])
  try:
    rows = sweep.run_sweep(spec, out, progress=_Progress(), eval_metrics=args.eval_metrics,
                           eval_protocol=args.eval_protocol)
  except KeyboardInterrupt:
    print(f"[blx] {sweep.INTERRUPTED}", file=sys.stderr)
    return INTERRUPTED_STATUS
  with open(os.path.join(out, "summary.md")) as f:
    print(f.read())
  print(f"[blx] {len(rows)} runs; tables in {out}/summary.{{md,csv,tex}}", file=sys.stderr)
  return 0


def _train_epilog() -> str:
  """Envs, objectives with their options, and PPO keys with their defaults, for ``train --help``."""
  import dataclasses
  import textwrap
  with contextlib.redirect_stdout(io.StringIO()):  # mjx's optional-backend notice
    from blx import envs, objectives, training
  wrap = lambda text: textwrap.fill(text, 96, initial_indent="  ", subsequent_indent="    ")
  lines = ["envs (`blx envs NAME` shows one, with its observation names):",
           wrap(", ".join(envs.list_envs())), "",
           "objectives and their options (--option KEY=VALUE):"]
  for name in objectives.list_objectives():
    options = [o for o in objectives.options_of(name) if o != "env"]
    lines.append(wrap(f"{name}: {', '.join(options) or '(none)'}"))
  config = training.ppo_defaults("ant")
  lines += ["", "PPO config keys (--config KEY=VALUE), with the ant row's defaults; point, humanoid",
            "and halfcheetah have their own rows (blx.training.ppo_defaults(ENV)):",
            wrap(", ".join(f"{f.name}={getattr(config, f.name)!r}"
                           for f in dataclasses.fields(config)))]
  return "\n".join(lines)


def _parser() -> argparse.ArgumentParser:
  parser = argparse.ArgumentParser(
      prog="blx", description="Compose, train, evaluate, render and sweep reward-free behaviour "
      "on MuJoCo MJX.", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=ENVIRONMENT)
  sub = parser.add_subparsers(dest="command", required=True)
  p = sub.add_parser("envs", help="list envs and components, or describe one env")
  p.add_argument("name", nargs="?")
  p.set_defaults(fn=cmd_envs)

  p = sub.add_parser("train", help="train an objective on an env into a run directory",
                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=_train_epilog())
  p.add_argument("--env", default=None, help=f"a registered env (default {DEFAULT_ENV})")
  p.add_argument("--objective", default=None, help=f"default {DEFAULT_OBJECTIVE}")
  p.add_argument("--num-skills", type=int, default=None,
                 help="skills of diayn / diayn_full (default 8, as the API and sweeps)")
  p.add_argument("--obs-indices", default=None,
                 help="a name such as vel_xy (see `blx envs ENV`) or a list such as [13,14]")
  p.add_argument("--steps", type=int, default=None, help="env steps (default: the env's PPO row)")
  p.add_argument("--agent", default=None,
                 help="multi-agent envs: pay the (reward-free) objective to this agent only; the "
                      "others keep their env rewards (default obs indices: the agent's xy "
                      "velocity)")
  p.add_argument("--seeds", default=None,
                 help="comma-separated, trained in one vmapped program (default 0)")
  p.add_argument("--config", action="append", metavar="KEY=VALUE", help="a PPOConfig field")
  p.add_argument("--option", action="append", metavar="KEY=VALUE", help="an objective option")
  p.add_argument("--env-param", action="append", metavar="KEY=VALUE", help="an env parameter")
  p.add_argument("--out", default=None, help="run directory (default runs/ENV_OBJ_TIME)")
  p.add_argument("--resume", nargs="?", const="", default=None, metavar="DIR",
                 help="continue the run in DIR (or --out) with its own config.json; flags given "
                      "with it must agree with the run")
  p.add_argument("--eval-metrics", action="store_true",
                 help="log MI / LGR / energy distance at every evaluation (slower)")
  add_eval_protocol_flag(p)
  p.set_defaults(fn=cmd_train)

  p = sub.add_parser("eval", help="the metrics of a trained run (eval.json once it has finished "
                     "training)")
  p.add_argument("dir")
  p.add_argument("--json", action="store_true")
  p.add_argument("--key-seeds", default=None, metavar="K,K,...",
                 help="evaluate once per evaluation key (e.g. 0,1,2) and report how far each "
                      "metric moves with the evaluation's own sampling; eval.json is not written")
  p.add_argument("--metrics-only", action="store_true",
                 help="with --key-seeds: the objective's metrics alone (MI, H(s), LGR, energy "
                      "distance, ...), without the trainer's return episodes (num_eval_envs per "
                      "seed), which cost most of an evaluation on a CPU")
  p.add_argument("--eval-actions", default=None, metavar="sampled|mean",
                 help="how the return episodes act, where not as the run's own (its "
                      "eval_actions: blx's default is sampled, as Braxlines' PPO evaluates; runs "
                      "before session 61 took mean); eval.json is then not written")
  p.add_argument("--eval-protocol", default=None, metavar="quick|final",
                 help="with --key-seeds: the sizes the paper's evaluator reads the checkpoint "
                      "with: final (eval.json's, the default) or quick (those of the curves "
                      "--eval-metrics logs during training), under the same keys")
  p.set_defaults(fn=cmd_eval)

  p = sub.add_parser("render", help="a video of rollouts (one per skill for MI-max)")
  p.add_argument("dir")
  p.add_argument("--skills", default=None, help="comma-separated skill numbers")
  p.add_argument("--out", default=None, help="default DIR/video.mp4")
  p.add_argument("--seed-index", type=int, default=0)
  p.add_argument("--steps", type=int, default=None, help="env steps per episode")
  p.add_argument("--width", type=int, default=320)
  p.add_argument("--height", type=int, default=240)
  p.set_defaults(fn=cmd_render)

  p = sub.add_parser("sweep", help="a grid x seeds from a JSON/YAML/Python spec, with tables")
  p.add_argument("spec")
  p.add_argument("--out", default=None)
  p.add_argument("--eval-metrics", action="store_true")
  add_eval_protocol_flag(p)
  p.set_defaults(fn=cmd_sweep)
  return parser


def add_eval_protocol_flag(parser) -> None:
  """``--eval-protocol``, as train, sweep and the benchmarks' studies take it."""
  parser.add_argument("--eval-protocol", choices=("quick", "final"), default=None,
                      help="with --eval-metrics: the rollouts of the metrics logged during "
                           "training, quick (4 episodes) or final (eval.json's 10); by default "
                           "a resumed run's own, else quick")


def _quiet_imports() -> None:
  """Imports mujoco without OpenGL (``blx._mujoco``; ``render`` loads a backend itself) and keeps
  mjx's optional-backend notice ("Failed to import warp", printed to stdout) out of the command's
  output (e.g. ``--json``)."""
  with contextlib.redirect_stdout(io.StringIO()):
    import blx._mujoco  # noqa: F401  (mujoco without OpenGL, whatever MUJOCO_GL says)
    import mujoco.mjx  # noqa: F401


def main(argv=None) -> int:
  args = _parser().parse_args(argv)
  _quiet_imports()
  if args.command != "envs":
    from blx.experiments import compile_cache
    compile_cache.enable()
  from blx.experiments.render import GLError
  from blx.experiments.runs import RunError
  from blx.training import NonFiniteError
  try:
    return args.fn(args)
  except (UsageError, RunError, ValueError, OSError, NonFiniteError, GLError) as e:  # one line
    if os.environ.get("BLX_DEBUG"):
      raise
    message = str(e).splitlines()[0] if str(e) else type(e).__name__
    if isinstance(e, OSError) and e.filename:  # e.g. --out under a file, or not writable
      message = f"{e.strerror or type(e).__name__}: {e.filename}"
    print(f"blx {args.command}: error: {message} (BLX_DEBUG=1 shows the traceback)",
          file=sys.stderr)
    return 2


def run_main(main_fn=None) -> None:
  """Runs a command-line program's ``main_fn`` (default the ``blx`` command's :func:`main`) and
  exits with its status (its return value, or the code of the ``SystemExit`` it raised).

  A program stopped by Ctrl-C (status 130) has kept its run's last checkpoint by then, and ends
  at once: its output is flushed and the interpreter is left without its shutdown. That shutdown
  would wait for the chunk still running on the device (up to a whole chunk, minutes, on a CPU)
  or stop the thread that dispatched it inside XLA, which aborts the process on a GPU
  ("FATAL: exception not rethrown", status 134). For ``if __name__ == "__main__"`` and the console
  script; tests call ``main`` itself. A Ctrl-C that ``main_fn`` does not catch itself (one
  outside training, e.g. in ``blx eval``) is the same exit, with one line instead of a traceback.

  Any other end while a chunk is still in flight (training's dispatch thread alive, as after a
  non-finite loss: ``training.NonFiniteError``) ends the same way, with its own status; a
  ``NonFiniteError`` that ``main_fn`` lets through is one line of error and status 2, as ``blx``
  gives it."""
  program = os.path.basename(sys.argv[0]) or "blx"
  try:
    status = (main_fn or main)()
  except SystemExit as e:
    status = e.code
  except KeyboardInterrupt:
    print(f"{program}: interrupted", file=sys.stderr)
    status = INTERRUPTED_STATUS
  except Exception as e:  # noqa: BLE001  (only training's NonFiniteError is caught)
    loop = sys.modules.get("blx.training.loop")  # not loaded: no training, so not its error
    if loop is None or not isinstance(e, loop.NonFiniteError):
      raise
    print(f"{program}: error: {e}", file=sys.stderr)
    status = 2
  if status == INTERRUPTED_STATUS or (isinstance(status, int) and _chunk_in_flight()):
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)
  sys.exit(status)


def _chunk_in_flight() -> bool:
  """Whether training's dispatch thread (``training.loop.DISPATCH_THREAD``) is still running a
  chunk on the device."""
  import threading

  loop = sys.modules.get("blx.training.loop")  # not loaded: nothing was trained
  return loop is not None and any(t.name == loop.DISPATCH_THREAD and t.is_alive()
                                  for t in threading.enumerate())


if __name__ == "__main__":
  run_main()
