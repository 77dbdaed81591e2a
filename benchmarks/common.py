"""What the benchmark scripts share: raw ``mjx.step`` on an env's model, timing a jitted call,
their Markdown tables, and what the analyses of a finished run share: their common options, how
they pick its seeds and name it, and how they write their JSON."""

from __future__ import annotations

import json
import os
import time
from typing import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from blx import envs, metrics
from blx.experiments import runs
from blx.objectives.specs import MimaxSpec
from blx.training import PPOConfig
from blx.training import config as ppo_config


def raw_physics_runner(env) -> Callable:
  """Jitted ``(data [N], actions [T, N, A]) -> scalar``: T env steps of bare ``mjx.step`` on the
  env's compiled model, ``substeps`` physics steps each with the action as ``ctrl``, vmapped as the
  env is. The scalar (a sum of qpos) only forces the work."""
  base = envs.unwrap(env)

  @jax.jit
  def run(data, actions):
    def one(d, a):
      d = d.replace(ctrl=a)
      d = jax.vmap(lambda x: jax.lax.fori_loop(
          0, base.substeps, lambda _, y: mjx.step(base.mjx_model, y), x))(d)
      return d, d.qpos.sum()
    return jax.lax.scan(one, data, actions)[1].sum()

  return run


def env_step_runner(env, num_envs: int, steps: int) -> tuple[Callable, tuple]:
  """A jitted ``(state [N], actions [T, N, A]) -> scalar``: T steps of the env's own vmapped
  ``step`` (physics, observations, rewards, termination), and its arguments: ``num_envs`` reset
  states and uniform random actions. The scalar (a sum of rewards) only forces the work."""
  keys = jax.random.split(jax.random.PRNGKey(0), num_envs)
  state = jax.jit(jax.vmap(env.reset))(keys)
  actions = jax.random.uniform(jax.random.PRNGKey(1), (steps, num_envs, env.action_size),
                               minval=-1, maxval=1)

  @jax.jit
  def run(state, actions):
    def one(s, a):
      s = jax.vmap(env.step)(s, a)
      return s, s.reward.sum()
    return jax.lax.scan(one, state, actions)[1].sum()

  return run, (state, actions)


def time_calls(fn, args_for, repeats: int) -> tuple[float, list[float]]:
  """Compile seconds and the wall seconds of each of ``repeats`` calls of ``fn(*args_for(i))``: a
  first call (``i`` = 0, compile included) timed apart, then calls ``i`` = 1..repeats, each
  waited for."""
  t = time.perf_counter()
  jax.block_until_ready(fn(*args_for(0)))
  first = time.perf_counter() - t
  times = []
  for i in range(repeats):
    t = time.perf_counter()
    jax.block_until_ready(fn(*args_for(i + 1)))
    times.append(time.perf_counter() - t)
  return first, times


def print_table(header: str, rows: Sequence[dict], columns: Sequence[tuple[str, str, str]],
                first: str = "---") -> None:
  """A device line (``header`` appended), then a Markdown table with one ``(label, key, format
  spec)`` per column; the first column is aligned by ``first``, the others right."""
  print(f"\ndevice: {jax.devices()[0].device_kind}; jax {jax.__version__}{header}")
  print("| " + " | ".join(label for label, _, _ in columns) + " |")
  print(f"| {first} |" + " ---: |" * (len(columns) - 1))
  for r in rows:
    print("| " + " | ".join(format(r[key], spec) for _, key, spec in columns) + " |")


def one_iteration_per_chunk(config: PPOConfig, chunks: int = 100) -> PPOConfig:
  """``config`` with a run of ``chunks`` chunks of one PPO iteration each, for timing a jitted chunk
  back to back (``num_timesteps`` stays within PPOConfig's 2**31 - 1 up to 16 M env steps per
  iteration)."""
  return config.replace(num_timesteps=config.env_steps_per_iteration * chunks, num_evals=chunks)


def add_analysis_arguments(parser, run_help: str) -> None:
  """The options every analysis of a finished run takes: the run directory (``run_help`` says
  which runs it reads), ``--seeds``, ``--deterministic`` and ``--out``."""
  parser.add_argument("run", help=run_help)
  parser.add_argument("--seeds", default=None,
                      help="comma-separated positions in the run's seeds (default all)")
  parser.add_argument("--deterministic", action="store_true", help="take the mean actions")
  parser.add_argument("--out", default=None,
                      help="the JSON file to write (default: one in the run directory)")


def write_json(path: str, value) -> None:
  """Writes ``value`` to ``path`` as indented JSON through a temporary file: a write that fails or
  is killed leaves the last whole file, never half of one."""
  tmp = path + ".tmp"
  try:
    with open(tmp, "w") as f:
      json.dump(value, f, indent=2)
  except BaseException:
    if os.path.exists(tmp):
      os.remove(tmp)
    raise
  os.replace(tmp, path)


def env_params(pairs: Sequence[str]) -> dict:
  """``--env-param``'s ``["num_legs=4", ...]`` as ``{"num_legs": 4}`` (values read as JSON where
  they parse, else kept as text). ``ValueError`` naming a pair that is not KEY=VALUE."""
  params = {}
  for pair in pairs:
    key, sep, value = pair.partition("=")
    if not sep or not key:
      raise ValueError(f"--env-param takes KEY=VALUE, got {pair!r}")
    try:
      params[key] = json.loads(value)
    except json.JSONDecodeError:
      params[key] = value
  return params


def seed_positions(text: str | None, num_seeds: int, flag: str = "--seeds") -> list[int]:
  """The positions in a run's ``num_seeds`` seeds that the option ``flag`` names (``"0,2"``;
  every one where ``text`` is None). ``ValueError`` naming what is wrong and what is valid."""
  try:
    picked = list(range(num_seeds)) if text is None else [int(s) for s in text.split(",")]
  except ValueError:
    raise ValueError(f"{flag} {text!r}: give comma-separated positions, e.g. 0,1") from None
  bad = [p for p in picked if not 0 <= p < num_seeds]
  if bad:
    raise ValueError(f"{flag} {','.join(map(str, bad))}: the run has {num_seeds} seeds, "
                     f"positions 0..{num_seeds - 1}")
  return picked


def load_picked(parser, run_dir: str, seeds: str | None) -> tuple:
  """``(run, picked)``: the run at ``run_dir`` and the positions ``--seeds`` names in its seeds
  (``seed_positions``); a run that cannot be loaded or a bad ``--seeds`` is ``parser.error``."""
  try:
    run = runs.load_run(run_dir)
    return run, seed_positions(seeds, len(run.spec.seeds))
  except (runs.RunError, ValueError) as e:
    parser.error(str(e))


def seed_table(values: dict, title: str = "metric") -> str:
  """A Markdown table of per-seed ``values`` (``{name: [seeds, ...]}``): each name's mean +- std
  over seeds, one per trailing element (e.g. per observed dimension), comma-separated."""
  lines = [f"| {title} | mean +- std over seeds |", "| --- | ---: |"]
  for name, v in values.items():
    a = np.asarray(v, np.float64)
    a = a.reshape(a.shape[0], -1)
    lines.append(f"| {name} | " + ", ".join(f"{a[:, j].mean():.3f} +- {a[:, j].std():.3f}"
                                           for j in range(a.shape[1])) + " |")
  return "\n".join(lines)


def picked_seeds(run, picked: Sequence[int], key_seed: int) -> tuple:
  """``(params, keys)`` of the seeds at positions ``picked`` of a loaded run: its params with the
  seed axis cut to them, and a key for each, split from ``PRNGKey(key_seed)`` over all the run's
  seeds, so that a seed's key does not depend on which others are picked."""
  at = np.asarray(picked)
  keys = jax.random.split(jax.random.PRNGKey(key_seed), len(run.spec.seeds))[at]
  return jax.tree.map(lambda x: x[at], run.params), keys


def require_discrete_skills(run, parser, why: str, *, continuous: bool = False) -> bool:
  """``parser.error`` unless a loaded run's objective is MI-max with discrete skills (a categorical
  prior), or with ``continuous`` also a continuous prior (``metrics.draws_latents``: the evaluator
  draws its latents and reads each as a skill), naming its prior and the valid ones; ``why`` says
  what the analysis needs them for. Returns whether the prior is continuous."""
  spec = run.objective.spec
  kind = spec.prior.kind if isinstance(spec, MimaxSpec) else None
  drawn = metrics.draws_latents(run.objective)
  if kind != "categorical" and not (continuous and drawn):
    valid = "'categorical'" + (" or a continuous one such as 'uniform'" if continuous else "")
    parser.error(f"{run.directory}: {run.spec.objective} is not an MI-max objective with "
                 f"{'skills or latents' if continuous else 'discrete skills'} (prior {kind!r}, "
                 f"valid: {valid}); {why}")
  return drawn


POLICY_LATENTS = 8  # the draws of a continuous prior an analysis rolls a policy out under


def policy_latents(run, key: jax.Array,
                   num_latents: int = POLICY_LATENTS) -> tuple[jax.Array, bool]:
  """``(latents [L, Z], conditioned)``: what a loaded run's policy is rolled out under in the
  analyses. Where it takes a latent (its objective's ``conditions_policy``, an MI-max run's), the
  evaluator's (``metrics.latents_for_evaluation``: every skill of a categorical prior,
  ``num_latents`` draws of a continuous one, with ``key``); else one empty latent ``[1, 0]``."""
  conditioned = bool(run.objective.conditions_policy)
  return (metrics.latents_for_evaluation(run.objective, key, num_latents) if conditioned
          else jnp.zeros((1, 0))), conditioned


def run_label(spec, seeds: str | None = None, *, directory: str | None = None) -> str:
  """"OBJECTIVE on ENV, N seeds" for a run's ``RunSpec``, with the env's edits where it has any
  (an ablation) and, after it, its PPO settings off the env's row (``off_row_text``; e.g.
  "; PPO max_grad_norm 5 (default None)"), so that an option's figure does not read as the
  paper's row; ``seeds`` replaces "N seeds" (e.g. "seed 3"). With the run's ``directory``, every
  setting it trained with is compared (``runs.settings_as_trained``: also one it took from a
  default that moved since); else those its spec sets. The analyses roll out episodes of their
  own, so the settings of the run's return episodes alone (``eval_actions``) are left out."""
  edits = (spec.env_params or {}).get("edits")
  where = f"{spec.env} ({', '.join(f'{k} {v}' for k, v in edits.items())})" if edits else spec.env
  settings = (spec.ppo if directory is None
              else runs.settings_as_trained(spec.ppo, runs.read_provenance(directory)))
  options = ppo_config.off_row_text(spec.env, settings, returns=False)
  return (f"{spec.objective} on {where}, {seeds or f'{len(spec.seeds)} seeds'}"
          + (f"; {options}" if options else ""))


def action_names(env) -> tuple[str, ...]:
  """The MJCF name of the joint each action of ``env`` (an ``Env`` or a wrapper) drives, in action
  order; ``action i`` for each where the env has no MuJoCo model."""
  m = getattr(envs.unwrap(env), "mj_model", None)
  if m is None:
    return tuple(f"action {i}" for i in range(env.action_size))
  return tuple(m.joint(int(m.actuator_trnid[i, 0])).name for i in range(m.nu))
