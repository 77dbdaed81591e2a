"""Whether falls account for a low MI-max or D-min row (#15): rolls a finished run out the paper's way
and splits the scored states into those taken before each episode ended and those after.

    python benchmarks/fall_analysis.py RUN_DIR [--seeds 0,1] [--deterministic | --noise-scale S]
                                               [--draws 5] [--out FILE.json]
    python benchmarks/fall_analysis.py RUN_DIR --plot   # falls.png from what has run
    python benchmarks/fall_analysis.py RUN_DIR --trend [--since STEPS] [--evals EVAL_JSON ...]
                                               [--plot]   # MI against the alive share
    python benchmarks/fall_analysis.py DIR --noise-curve [--against DIR ...] [--labels L ...]
                                               # alive share and MI against the action noise
    python benchmarks/fall_analysis.py RUN_DIR --noise-on JOINT [JOINT ...]  # noise on those
    python benchmarks/fall_analysis.py DIR --by-joints   # which joints' noise fells the bodies
    python benchmarks/fall_analysis.py RUN_DIR --blind PART [PART ...]  # the policy blind to them

Per seed, on the paper's skill episodes (each skill's latent, 10 episodes of the env's length, the
last 500 steps scored, actions sampled unless ``--deterministic``; no reset after a fall, as in
Braxlines' evaluation):
- ``mi``, ``entropy``: MI and H(s) over every state of blx's window, the last 500 steps (as
  ``eval/mi`` and ``eval/entropy`` in ``eval.json``, on other random episodes);
- ``alive_share``: the share of scored states taken before their episode ended;
- ``mi_alive``, ``entropy_alive``: MI and H(s) of those states alone (``metrics.alive_mask``);
- ``mi_subset``: the control. MI of random subsets that keep as many states of each skill as the
  alive ones, drawn uniformly from the skill's scored states (mean of ``--draws``). The plug-in
  estimator reads higher on fewer samples; this is how much of ``mi_alive`` that explains;
- ``speed_alive``, ``speed_after``: the mean norm of the scored feature (e.g. the xy velocity)
  before and after the falls;
- ``end_step``: the median step at which an episode ended (the episode length if none did);
  ``last_end_step``: the latest. Braxlines' rollout stops once every episode of the batch has
  ended, so where this is below the episode length its scored window would have ended there
  (blx's evaluator always runs the whole episode);
- ``braxlines_end``, ``mi_braxlines``: the step before which Braxlines' rollout of the same
  episodes stops (the first at which every episode is done at once, by the per-step done flags)
  and the MI of the window it would score (``metrics.braxlines_window``: the last 500 states it
  kept, the reset state included). The protocol's window, shifted by one step, when
  ``braxlines_end`` is the episode length.

A D-min run (GAIL, AIRL, ...) is rolled out as its evaluator does (10 episodes, every 10th of the
last 500 steps scored against the target's samples) and gets, per seed:
- ``energy_distance``: the energy distance of every state of blx's window (as
  ``eval/energy_distance`` in ``eval.json``, on other random episodes); ``alive_share`` as above;
- ``energy_distance_alive``: the scored states taken before the fall alone (NaN where there are
  none);
- ``energy_distance_upright``: every 10th state of the whole episode up to its fall, scored or not:
  what the policy does while it is up (a diagnostic; the protocol never scores these early steps);
  ``upright_share``: the share of the whole episode's states taken before the fall;
- ``speed_upright``, ``speed_after``: the mean norm of the matched feature while up and, among the
  scored states, after the fall;
- ``end_step``, ``last_end_step``, ``mean_end_step``: as above, and the mean;
- ``braxlines_end``, ``energy_distance_braxlines``: as above for MI: the energy distance of the
  window Braxlines' evaluator would score on the same 10 episodes (where every episode falls early,
  the states before the falls, from the reset on);
- ``feature_upright/<obs index>``: the mean of each matched feature (signed) over the states
  before the fall: which way, and how fast, a seed goes while it is up;
- ``episode_mode_share_upright/k`` (a target of several modes): the share of episodes whose states
  before the fall are mostly nearest to mode k. A policy that picks one mode in every episode
  scores 1 on it; one that matches the target, 1/K on each;
- ``logit_mode/k``, ``logit_upright`` (a learned discriminator: GAIL, GAIL2, AIRL, FAIRL): the
  discriminator's clipped logit, which the reward transforms, averaged over the target's samples
  nearest mode k, and over the policy's own states before the fall. Whether the learned reward
  still pays for a mode the policy never runs.
It also prints the energy distance of a body at rest (every state at 0), the reference a policy
that never moves would score.

``--noise-scale S`` samples the pre-tanh action at S times the policy's std around its mean (1: the
protocol's sampled actions, 0: the mean actions): how much action noise the body stays up under.
A diagnostic, never the protocol. (The scaled action is tanh(m + S (u - m)), with m and u
recovered from the policy's mean and sampled actions by arctanh, clipped at |a| = 1 - 1e-6.)

``--trend [--since STEPS]`` reads only metrics.csv (no rollout): every quick evaluation at or after
STEPS env steps per seed (default all) where every seed has a value is a point (alive share, MI),
one per seed. It fits the MI (``eval/mi``) against the alive share by least squares and prints the
fit, Pearson's r, the alive share at which the fit reaches the paper's MI, the mean alive share at
the last evaluation and its least-squares rate over the window's evaluations, per 10 M env steps,
and the policy's entropy (``policy/entropy``, of its tanh-squashed actions) at the window's first
and last evaluation. The env steps at which that rate would bring the alive share to the paper's MI
is a straight-line extrapolation, printed as one, never a measurement. Writes
RUN_DIR/alive_trend.json (or ``--out``); with ``--plot``, falls.png gains a panel of the points and
the fit. ``--evals EVAL_JSON ...`` adds the seeds of evaluations at the protocol's sizes (eval.json
files, or run directories holding one; the quick evaluations' sizes are smaller) and their own fit.

``--noise-on JOINT [JOINT ...]`` samples only the actions of the joints whose MJCF names match a
pattern (fnmatch, on the full name or after its last '/': ``'*hip*' '*knee*'`` for the humanoid's
legs), at ``--noise-scale`` (default 1), and takes the mean action on the others: which joints'
noise fells the bodies. A pattern that matches no actuated joint is refused, naming them. Writes
fall_analysis_on_PATTERNS.json (``_S`` appended at a scale S). A diagnostic, never the protocol.
``--blind PART [PART ...]`` holds the observation's parts whose names (the env's ``obs_layout``,
e.g. ``agent1/actuator_force``, ``agent1/contact_vel``) match a pattern (fnmatch, on the full name
or after its last '/') at the running means the policy normalises its input with, at every step:
the policy sees their average whatever the body does. How much the alive share and the MI fall
tells how much the gait uses those parts. It composes with the rollout's other options (sampled
actions by default, ``--deterministic``, ``--noise-scale``). A pattern that matches no part is
refused, naming them. Writes fall_analysis_blind_PATTERNS.json (or ..._deterministic.json, ...).
A diagnostic, never the protocol.
``--by-joints`` rolls nothing out: it reads DIR's ``--noise-on`` analyses at scale 1 between the
mean actions (fall_analysis_deterministic.json) and the protocol's (fall_analysis.json), all on the
same keys, and prints the alive share (with its change from the mean actions, paired t-test over
seeds), the MI and the MI before the falls, and draws DIR/joint_noise.png (or ``--out``).

``--noise-curve`` rolls nothing out: it reads the MI-max analyses already in DIR (a run directory
or a folder of committed analyses: fall_analysis.json at scale 1, the protocol's sampled actions;
fall_analysis_deterministic.json at 0; fall_analysis_noise_S.json at S), and those of each
``--against`` directory, and draws DIR/noise_curve.png (or ``--out``): the alive share and the MI
(every scored state, and the states before the falls) against the action noise, mean +- std over
seeds, one line per directory (named by ``--labels``, else by the directory's name), beside the
paper's MI where a config in DIR names its row. It prints the same as a table. Each directory needs
two scales at least.

Prints the mean +- std over seeds, and the Pearson correlation over seeds of the protocol's MI with
the alive share (D-min: of the energy distance with the mean end of an episode); writes every
per-seed value to ``--out`` (default RUN_DIR/fall_analysis.json, or
fall_analysis_deterministic.json, or fall_analysis_noise_S.json), with the env steps per seed of the
checkpoint analysed (``env_steps``: a run under training is analysed where it stands).

``--plot`` draws RUN_DIR/falls.png: the protocol's MI and the alive-only MI over training beside
the paper's MI (mean +- std over seeds, from metrics.csv; the run must have been trained with
``--eval-metrics``), the alive share over training, and, from fall_analysis.json, each seed's MI
against its alive share. For a D-min run: the energy distance over training beside the paper's,
the length of PPO's evaluation episodes over training, and each seed's energy distances against
the mean end of its episodes.
"""

from __future__ import annotations

import argparse
import dataclasses
import fnmatch
import glob
import json
import os
import re
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ablations  # noqa: E402
import common  # noqa: E402

from blx import envs, metrics  # noqa: E402
from blx.experiments import plots, runs  # noqa: E402
from blx.objectives.specs import DminSpec, MimaxSpec  # noqa: E402

BINS = 1000


def scaled_noise(policy, scale, where=None):
  """``policy`` with its pre-tanh sampling noise multiplied by ``scale`` (see the module's doc);
  ``where``, a boolean per action: the noise on those alone, the mean action on the others."""
  limit = 1.0 - 1e-6
  factor = scale if where is None else scale * jnp.asarray(where, jnp.float32)

  def noisy(params, obs, z=None, key=None, deterministic=False):
    mean = jnp.arctanh(jnp.clip(policy(params, obs, z, deterministic=True), -limit, limit))
    sampled = jnp.arctanh(jnp.clip(policy(params, obs, z, key=key, deterministic=False),
                                   -limit, limit))
    return jnp.tanh(mean + factor * (sampled - mean))

  return noisy


def _noisy_policy(run: runs.Run, noise_scale: float | None, noise_on, blind=None):
  """The run's policy as the rollout samples it: as trained where neither ``noise_scale`` nor
  ``noise_on`` is given, else ``scaled_noise`` (scale 1 where only ``noise_on`` is); ``blind``,
  observation indices, held at their running means (``blinded``)."""
  policy = run.policy if blind is None else blinded(run.policy, blind)
  if noise_scale is None and noise_on is None:
    return policy
  return scaled_noise(policy, 1.0 if noise_scale is None else noise_scale, noise_on)


def blinded(policy, indices):
  """``policy`` (``policy(params, obs, z, key, deterministic)``, ``params`` a ``PolicyParams``)
  with the observation entries ``indices`` replaced by the running mean of its input normaliser
  there: the policy sees their average, whatever the body does. The mean comes with the seed's
  parameters, so a vmap over seeds blinds each seed with its own."""
  indices = jnp.asarray(indices, jnp.int32)

  def blind(params, obs, z=None, key=None, deterministic=True):
    mean = jnp.broadcast_to(params.normalizer.mean[indices], obs[..., indices].shape)
    return policy(params, obs.at[..., indices].set(mean), z, key=key,
                  deterministic=deterministic)

  return blind


def blind_indices(layout: dict[str, slice], patterns: list[str]) -> tuple[list[int], list[str]]:
  """The observation indices of the parts of ``layout`` (an env's ``obs_layout``) whose names
  match any of ``patterns`` (fnmatch, on the full name and on the part after the last '/'), and
  those parts' names; each pattern must match one at least."""
  names = list(layout)
  parts = list(dict.fromkeys(  # in the patterns' order, each part once
      names[i] for hit in _hits(names, patterns, "--blind", "the observation's parts", names)
      for i in hit))
  return sorted({i for name in parts for i in range(layout[name].start, layout[name].stop)}), parts


def _hits(names, patterns: list[str], flag: str, what: str, shown) -> list[list[int]]:
  """Per pattern (fnmatch, on a full name or on its part after the last '/'), the positions in
  ``names`` it matches; a ValueError for one that matches none, naming ``what`` ``flag`` chooses
  from (``shown``)."""
  hits = []
  for pattern in patterns:
    hit = [i for i, name in enumerate(names) if fnmatch.fnmatchcase(name, pattern)
           or fnmatch.fnmatchcase(name.rsplit("/", 1)[-1], pattern)]
    if not hit:
      raise ValueError(f"{flag} {pattern!r} matches none of {what}: {', '.join(shown)}")
    hits.append(hit)
  return hits


def _slug(patterns: list[str]) -> str:
  """``patterns`` as a part of a file name."""
  return re.sub(r"[^A-Za-z0-9]+", "_", "+".join(patterns)).strip("_") or "all"


def noisy_actions(names: tuple[str, ...], patterns: list[str]) -> np.ndarray:
  """Which of the actions driving joints ``names`` match any of ``patterns`` (fnmatch, on the full
  name and on the part after the last '/'); each pattern must match one at least."""
  where = np.zeros(len(names), bool)
  for hit in _hits(names, patterns, "--noise-on", "the actuated joints",
                   [n.rsplit("/", 1)[-1] for n in names]):
    where[hit] = True
  return where


def blind_name(patterns: list[str], name: str) -> str:
  """The file name of an analysis ``name`` (e.g. fall_analysis.json) with the policy blind to the
  observation's parts matching ``patterns``: fall_analysis_blind_PATTERNS[...].json."""
  return name.replace("fall_analysis", f"fall_analysis_blind_{_slug(patterns)}", 1)


def noise_on_name(patterns: list[str], scale: float | None) -> str:
  """The analysis' file name for noise on ``patterns`` alone, at ``scale`` (None: 1)."""
  return f"fall_analysis_on_{_slug(patterns)}" + ("" if scale is None else f"_{scale:g}") + ".json"


@dataclasses.dataclass(frozen=True)
class AliveFit:
  """The least-squares line ``mi = intercept + slope * alive share`` over ``points`` (seed,
  evaluation) pairs, and Pearson's ``r`` over them (NaN where the MI has no spread)."""

  points: int
  intercept: float
  slope: float
  r: float

  def alive_for(self, mi: float) -> float:
    """The alive share at which the line reads ``mi`` (NaN where it is flat)."""
    return (mi - self.intercept) / self.slope if self.slope else float("nan")


def least_squares(x, y) -> tuple[float, float]:
  """The least-squares line ``y = intercept + slope * x`` as ``(slope, intercept)``, from centred
  sums, so that a ``y`` that does not change gives a slope of 0 exactly (np.polyfit's solver leaves
  a rounding residue there that BLAS builds differ on). ``x`` must have a spread."""
  x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
  dx = x - x.mean()
  slope = float(np.dot(dx, y - y.mean()) / np.dot(dx, dx))
  return slope, float(y.mean() - slope * x.mean())


def fit_alive(alive, mi) -> AliveFit:
  """``AliveFit`` of the paired values ``alive`` and ``mi``. Raises ValueError where there are
  fewer than two or the alive share has no spread."""
  x, y = np.asarray(alive, dtype=float), np.asarray(mi, dtype=float)
  if x.shape != y.shape or x.size < 2:
    raise ValueError(f"a fit needs two or more (alive share, MI) pairs, got {x.size} and {y.size}")
  if np.ptp(x) == 0:
    raise ValueError(f"the alive share is {x[0]:g} at every point: nothing to fit")
  slope, intercept = least_squares(x, y)
  r = float(np.corrcoef(x, y)[0, 1]) if np.ptp(y) else float("nan")
  return AliveFit(points=int(x.size), intercept=float(intercept), slope=float(slope), r=r)


@dataclasses.dataclass(frozen=True)
class AliveTrend:
  """How the quick evaluations' MI follows the alive share over a window of training (``--trend``
  in the module's doc): ``fit`` over every seed's evaluations from ``since`` to ``last_step`` env
  steps per seed; ``alive_last`` the mean alive share at the last, ``alive_rate`` the slope of the
  mean alive share over the window's evaluations, per 10 M env steps; ``policy_entropy`` the mean
  over seeds of the policy's entropy (``policy/entropy``, of its squashed actions) at the window's
  first and last evaluation, where metrics.csv logs it."""

  since: float
  last_step: float
  fit: AliveFit
  alive_last: float
  alive_rate: float
  policy_entropy: tuple[float, float] | None = None

  def steps_for(self, mi: float) -> float:
    """Env steps per seed at which the window's straight-line alive rate brings the alive share to
    ``fit.alive_for(mi)``: an extrapolation (``last_step`` where it is there already, inf where the
    share does not rise, NaN where the fit is flat)."""
    gap = self.fit.alive_for(mi) - self.alive_last
    if not np.isfinite(gap):
      return float("nan")
    if gap <= 0:
      return self.last_step
    return self.last_step + gap / self.alive_rate * 1e7 if self.alive_rate > 0 else float("inf")


def trend_points(rows: list[dict], since: float = 0.0) -> dict[float, dict[int, tuple]]:
  """``{env steps: {seed: (alive share, MI)}}`` of metrics.csv ``rows`` at every evaluation from
  ``since`` env steps per seed on where every seed has both."""
  mi, alive = ablations.by_step(rows, "eval/mi"), ablations.by_step(rows, "eval/alive_share")
  if not alive:
    raise ValueError("metrics.csv has no eval/alive_share: train with --eval-metrics (and a blx "
                     "that logs it)")
  seeds = max(len(v) for v in alive.values())
  return {s: {k: (alive[s][k], mi[s][k]) for k in sorted(alive[s])}
          for s in sorted(set(mi) & set(alive))
          if s >= since and len(set(mi[s]) & set(alive[s])) == seeds}


def alive_trend(rows: list[dict], since: float = 0.0) -> AliveTrend:
  """``AliveTrend`` of metrics.csv ``rows`` from ``since`` env steps per seed on. Raises ValueError
  where the rows hold no alive share, or the window fewer than two evaluations with every seed's
  MI and alive share, or no spread in the alive share to fit."""
  points = trend_points(rows, since)
  if len(points) < 2:
    steps = sorted(ablations.by_step(rows, "eval/alive_share"))
    raise ValueError(f"the window from {since:,.0f} env steps holds {len(points)} evaluation(s) "
                     f"with every seed's MI and alive share; it needs 2 (the evaluations run from "
                     f"{steps[0]:,.0f} to {steps[-1]:,.0f})")
  pairs = [v for at in points.values() for v in at.values()]
  fit = fit_alive([a for a, _ in pairs], [m for _, m in pairs])
  steps = list(points)
  means = [np.mean([a for a, _ in points[s].values()]) for s in steps]
  rate, _ = least_squares(np.array(steps) / 1e7, means)  # per 10 M env steps
  noise = ablations.by_step(rows, "policy/entropy")
  ends = [noise.get(steps[0]), noise.get(steps[-1])]
  entropy = (tuple(float(np.mean(list(v.values()))) for v in ends)
             if all(v and len(v) == len(points[steps[0]]) for v in ends) else None)
  return AliveTrend(since=float(steps[0]), last_step=float(steps[-1]), fit=fit,
                    alive_last=float(means[-1]), alive_rate=float(rate), policy_entropy=entropy)


def evaluation_fit(paths: list[str]) -> tuple[AliveFit, list[tuple[float, float]]]:
  """``AliveFit`` over every seed of the protocol's evaluations ``paths`` (eval.json files, or run
  directories holding one, as ``paper_tables.read_eval`` reads them, with per-seed
  ``eval/alive_share`` and ``eval/mi``), and the pairs it was fitted on."""
  pairs = []
  for path in paths:
    path, evaluation = ablations.paper_tables.read_eval(path)
    per_seed = evaluation.get("per_seed", {})
    if "eval/alive_share" not in per_seed or "eval/mi" not in per_seed:
      raise ValueError(f"{path}: no per-seed eval/alive_share and eval/mi (an MI-max run's "
                       "eval.json, evaluated by a blx that reports the alive share)")
    pairs += list(zip(per_seed["eval/alive_share"], per_seed["eval/mi"]))
  return fit_alive([a for a, _ in pairs], [m for _, m in pairs]), pairs


def analyse(run: runs.Run, params, key: jax.Array, *, deterministic: bool, draws: int,
            num_latents: int = 10, episodes_per_latent: int = 10,
            noise_scale: float | None = None, noise_on=None, blind=None) -> dict:
  """The per-seed figures above for one seed's ``params`` (no seed axis); ``noise_scale`` (with
  ``deterministic`` False) scales the sampling noise; ``noise_on``, a boolean per action, keeps it
  on those actions alone (``noisy_actions``); ``blind``, observation indices the policy sees at
  their running means (``blinded``)."""
  objective = run.objective
  indices = np.asarray(metrics.eval_indices(objective))
  scale = objective.spec.obs_scale
  last = metrics.scored_steps(run.env)
  z_key, roll_key, draw_key = jax.random.split(key, 3)
  latents = metrics.latents_for_evaluation(objective, z_key, num_latents)
  num = latents.shape[0]
  policy = _noisy_policy(run, noise_scale, noise_on, blind)
  before, obs, done = metrics.rollout(
      run.env, policy, params, latents, roll_key, episodes_per_latent=episodes_per_latent,
      deterministic=deterministic,
      record=lambda s, a, n: (s.obs[..., indices], n.obs[..., indices], n.done))
  states = obs[:, :, -last:]                          # [L, M, T, D]
  alive = metrics.alive_mask(done, last)              # [L, M, T]
  flat = states.reshape(-1, len(indices))
  labels = jnp.repeat(jnp.arange(num), states.shape[1] * states.shape[2])
  mi = lambda w: metrics.mutual_information(flat, labels, bins=BINS, value_range=(-scale, scale),
                                            num_labels=num, weights=w)
  every, kept = mi(None), mi(alive.reshape(-1))

  def subset(k):
    # Per skill, as many states as it kept alive, at uniformly random places among its scored ones.
    per_skill = alive.reshape(num, -1)
    u = jax.random.uniform(k, per_skill.shape)
    rank = jnp.argsort(jnp.argsort(u, axis=-1), axis=-1)
    return mi((rank < per_skill.sum(-1, keepdims=True)).astype(jnp.float32).reshape(-1))["mi"]

  control = jax.vmap(subset)(jax.random.split(draw_key, draws)).mean(0)
  brax = metrics.braxlines_mutual_information(before, done, last, bins=BINS,
                                              value_range=(-scale, scale))
  speed = jnp.linalg.norm(states, axis=-1)
  after = 1.0 - alive
  ended = envs.alive_before(jnp.moveaxis(done.astype(jnp.float32), -1, 0)).sum(0)  # [L, M]
  return {"mi": every["mi"].mean(), "entropy": every["entropy"].mean(),
          "alive_share": alive.mean(),
          "mi_alive": kept["mi"].mean(), "entropy_alive": kept["entropy"].mean(),
          "mi_subset": control.mean(),
          "speed_alive": (speed * alive).sum() / jnp.maximum(alive.sum(), 1.0),
          "speed_after": (speed * after).sum() / jnp.maximum(after.sum(), 1.0),
          "end_step": jnp.median(ended), "last_end_step": ended.max(),
          "mi_braxlines": brax["mi"].mean(), "braxlines_end": metrics.braxlines_end(done)}


def analyse_dmin(run: runs.Run, params, key: jax.Array, *, deterministic: bool,
                 num_episodes: int = 10, every: int | None = None,
                 noise_scale: float | None = None, noise_on=None, blind=None) -> dict:
  """The D-min figures of the module's doc for one seed's ``params`` (no seed axis). ``every``:
  the evaluator's (every 10th state, every state in episodes under 200 steps) unless given;
  ``noise_scale``, ``noise_on`` and ``blind`` as ``analyse``'s."""
  spec = run.objective.spec
  if every is None:
    every = 1 if envs.episode_steps(run.env, "fall_analysis") < 200 else 10
  indices = np.asarray(spec.obs_indices)
  target = jnp.asarray(spec.target.samples)[:, :len(indices)]
  last = metrics.scored_steps(run.env)
  policy = _noisy_policy(run, noise_scale, noise_on, blind)
  before, obs, done = metrics.rollout(
      run.env, policy, params, jnp.zeros((1, 0)), key, episodes_per_latent=num_episodes,
      conditions_policy=False, deterministic=deterministic,
      record=lambda s, a, n: (s.obs[..., indices], n.obs[..., indices], n.done))
  before, obs, done = before[0], obs[0], done[0]                # [M, T, D], [M, T]
  scored = obs[:, -last:][:, ::every].reshape(-1, len(indices))
  alive = metrics.alive_mask(done, last, every).reshape(-1)
  steps = done.shape[-1]
  whole = obs[:, ::every].reshape(-1, len(indices))
  up_t = metrics.alive_mask(done, steps)                                        # [M, T]
  up = up_t[:, ::every].reshape(-1)
  ended = envs.alive_before(jnp.moveaxis(done.astype(jnp.float32), -1, 0)).sum(0)  # [M]
  speed = lambda x, w: (jnp.linalg.norm(x, axis=-1) * w).sum() / jnp.maximum(w.sum(), 1.0)
  out = {f"feature_upright/{i}": (obs[..., k] * up_t).sum() / jnp.maximum(up_t.sum(), 1.0)
         for k, i in enumerate(spec.obs_indices)}
  means = spec.target.means
  if means is not None and len(means) > 1:
    # Per episode, the mode its states before the fall are mostly nearest to.
    means = jnp.asarray(means)[:, :len(indices)]
    nearest = jnp.argmin(((obs[..., None, :] - means) ** 2).sum(-1), axis=-1)   # [M, T]
    votes = (jax.nn.one_hot(nearest, len(means)) * up_t[..., None]).sum(1)      # [M, K]
    majority = jax.nn.one_hot(jnp.argmax(votes, -1), len(means)).mean(0)
    out.update({f"episode_mode_share_upright/{k}": majority[k] for k in range(len(means))})
    if spec.logit is not None:
      # What the learned reward pays at each mode: the discriminator's clipped logit, averaged over
      # the target's own samples nearest mode k.
      logits = jax.vmap(spec.logit, (None, 0))(params.objective, target)
      near = jax.nn.one_hot(jnp.argmin(((target[:, None] - means) ** 2).sum(-1), -1), len(means))
      out.update({f"logit_mode/{k}": (logits * near[:, k]).sum() / near[:, k].sum()
                  for k in range(len(means))})
  if spec.logit is not None:
    logits = jax.vmap(jax.vmap(spec.logit, (None, 0)), (None, 0))(params.objective, obs)
    out["logit_upright"] = (logits * up_t).sum() / jnp.maximum(up_t.sum(), 1.0)
  return out | {"energy_distance": metrics.energy_distance(scored, target),
          "alive_share": alive.mean(),
          "energy_distance_alive": metrics.energy_distance(scored, target, weights=alive),
          "energy_distance_upright": metrics.energy_distance(whole, target, weights=up),
          "upright_share": up.mean(),
          "speed_upright": speed(whole, up), "speed_after": speed(scored, 1.0 - alive),
          "end_step": jnp.median(ended), "last_end_step": ended.max(),
          "mean_end_step": ended.mean(),
          "energy_distance_braxlines": metrics.energy_distance(
              before.reshape(-1, len(indices)), target,
              weights=jnp.broadcast_to(metrics.braxlines_window(done, last, every),
                                       done.shape).reshape(-1)),
          "braxlines_end": metrics.braxlines_end(done)}


def _paper_row(env: str, objective: str) -> dict:
  """The paper's values for ``env``'s ``objective`` row (``paper_tables.PAPER``; empty where the
  paper has no such row)."""
  return ablations.paper_tables.PAPER.get(env, {}).get(objective, {})


def plot(directory: str, trend: AliveTrend | None = None, evaluations=None) -> str:
  """Draws ``directory/falls.png`` (see the module's doc), with ``trend``'s panel (and
  ``evaluations``, ``evaluation_fit``'s result, in it) where given, and returns its path."""
  import csv

  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  spec = runs.read_spec(directory)
  with open(os.path.join(directory, "metrics.csv")) as f:
    rows = list(csv.DictReader(f))
  analysis_path = os.path.join(directory, "fall_analysis.json")
  analysis = None
  if os.path.exists(analysis_path):
    with open(analysis_path) as f:
      analysis = json.load(f)
  if rows and "eval/energy_distance" in rows[0]:
    return _plot_dmin(directory, spec, rows, analysis, plt)
  if not rows or "eval/mi_alive" not in rows[0]:
    raise SystemExit(f"{directory}/metrics.csv has no eval/mi_alive: train with --eval-metrics "
                     "(and a blx that logs it)")
  paper_mi = _paper_row(spec.env, spec.objective).get("eval/mi")
  panels = 2 + bool(analysis) + bool(trend)
  fig, axes = plt.subplots(1, panels, figsize=(5 * panels, 3.8))

  band = lambda ax, key, label, color: _band(ax, rows, key, label, color)
  ax = axes[0]
  band(ax, "eval/mi", "MI, every scored state (the protocol)", "C0")
  band(ax, "eval/mi_alive", "MI, the states before each fall (0 while none)", "C1")
  if paper_mi:
    ax.axhline(paper_mi[0], color="k", ls="--", lw=1, label=f"the paper's MI ({paper_mi[0]})")
  ax.set_title("MI(s, z) over training (quick evaluations)")
  ax.set_ylabel("MI (nats)")
  ax.legend(fontsize=7)
  ax = axes[1]
  band(ax, "eval/alive_share", "alive share", "C2")
  ax.set_ylim(0, 1)
  ax.set_title("share of scored states taken before the fall")
  _over_training(axes[:2])
  if analysis:
    ax = axes[2]
    v = analysis["per_seed"]
    ax.scatter(v["alive_share"], v["mi"], color="C0", label="every scored state (the protocol)")
    ax.scatter(v["alive_share"], v["mi_alive"], color="C1", label="the states before each fall")
    ax.scatter(v["alive_share"], v["mi_subset"], color="C7", marker="x",
               label="random subsets of the same size (control)")
    if paper_mi:
      ax.axhspan(paper_mi[0] - paper_mi[1], paper_mi[0] + paper_mi[1], color="k", alpha=0.1,
                 label="the paper's MI, mean ± std")
    ax.set_xlabel("alive share of the seed's scored states")
    ax.set_ylabel("MI (nats)")
    actions = "mean" if analysis["deterministic"] else "sampled"
    ax.set_title(f"each seed at the end ({actions} actions, 10 episodes per skill)", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
  if trend:
    _plot_trend(axes[-1], rows, trend, evaluations, paper_mi)
  return _save(fig, plt, directory, f"{common.run_label(spec, directory=directory)}: how much of "
               "the MI the falls take (mean ± std over seeds)")


def _plot_trend(ax, rows, trend: AliveTrend, evaluations, paper_mi) -> None:
  """Each seed's quick evaluations in ``trend``'s window, MI against alive share, with the fit;
  ``evaluations`` (``evaluation_fit``'s result, or None): the protocol's evaluations' seeds and
  their fit."""
  points = trend_points(rows, trend.since)
  x, y, c = (np.array(v) for v in zip(*[(a, m, s / 1e6) for s, at in points.items()
                                         for a, m in at.values()]))
  dots = ax.scatter(x, y, c=c, cmap="viridis", s=14)
  ax.figure.colorbar(dots, ax=ax, label="env steps per seed (millions)")
  line = np.linspace(0.0, 1.0, 2)
  fit = trend.fit
  ax.plot(line, fit.intercept + fit.slope * line, color="k", lw=1,
          label=f"quick: MI = {fit.intercept:.2f} + {fit.slope:.2f} x share (r {fit.r:.2f})")
  if evaluations:
    fit, pairs = evaluations
    ax.scatter(*zip(*pairs), color="C3", marker="x", s=24,
               label="the protocol's evaluations, each seed")
    ax.plot(line, fit.intercept + fit.slope * line, color="C3", lw=1,
            label=f"protocol: MI = {fit.intercept:.2f} + {fit.slope:.2f} x share (r {fit.r:.2f})")
  if paper_mi:
    ax.axhspan(paper_mi[0] - paper_mi[1], paper_mi[0] + paper_mi[1], color="k", alpha=0.1,
               label="the paper's MI, mean ± std")
  ax.set_xlim(0, 1)
  ax.set_xlabel("alive share of the seed's scored states")
  ax.set_ylabel("MI (nats)")
  ax.set_title("MI against alive share, each seed (quick evaluations from "
               f"{trend.since / 1e6:.0f} M)", fontsize=9)
  ax.legend(fontsize=7, loc="upper left")
  ax.grid(alpha=0.3)


def _save(fig, plt, directory: str, title: str) -> str:
  """Titles ``fig``, writes it to ``directory/falls.png`` and returns the path."""
  fig.suptitle(plots.fit_title(title, fig), fontsize=10)
  fig.tight_layout()
  path = os.path.join(directory, "falls.png")
  fig.savefig(path, dpi=120)
  plt.close(fig)
  return path


def _over_training(axes) -> None:
  for ax in axes:
    ax.set_xlabel("env steps per seed (millions)")
    ax.grid(alpha=0.3)


def _band(ax, rows, key, label, color):
  steps, mean, std = ablations.curve(rows, key)
  x = [s / 1e6 for s in steps]
  ax.plot(x, mean, color=color, label=label)
  ax.fill_between(x, [m - d for m, d in zip(mean, std)], [m + d for m, d in zip(mean, std)],
                  color=color, alpha=0.2)


def _plot_dmin(directory, spec, rows, analysis, plt) -> str:
  paper_ed = _paper_row(spec.env, spec.objective).get("-eval/energy_distance")
  fig, axes = plt.subplots(1, 3 if analysis else 2, figsize=(18 if analysis else 10, 3.8))
  ax = axes[0]
  _band(ax, rows, "eval/energy_distance", "energy distance, blx's window (the last 500 steps)",
        "C0")
  if "eval/energy_distance_braxlines" in rows[0]:
    _band(ax, rows, "eval/energy_distance_braxlines", "energy distance, Braxlines' window", "C4")
  if paper_ed:
    ax.axhline(-paper_ed[0], color="k", ls="--", lw=1,
               label=f"the paper's energy distance ({-paper_ed[0]})")
  if analysis and "energy_distance_at_rest" in analysis:
    ax.axhline(analysis["energy_distance_at_rest"], color="C3", ls=":", lw=1,
               label=f"a body at rest ({analysis['energy_distance_at_rest']:.2f})")
  ax.set_title("energy distance to the target over training (lower is better)", fontsize=9)
  ax.set_ylabel("energy distance")
  ax.legend(fontsize=7)
  ax = axes[1]
  _band(ax, rows, "eval/episode_length", "PPO's evaluation episodes (mean actions)", "C2")
  ax.set_title("episode length: steps before the fall (1,000: none)", fontsize=9)
  ax.set_ylabel("steps")
  ax.legend(fontsize=7)
  _over_training(axes[:2])
  if analysis:
    ax = axes[2]
    v = analysis["per_seed"]
    ax.scatter(v["mean_end_step"], v["energy_distance"], color="C0",
               label="blx's window (the last 500 steps)")
    if "energy_distance_braxlines" in v:
      ax.scatter(v["mean_end_step"], v["energy_distance_braxlines"], color="C4", marker="s",
                 label="Braxlines' window (the paper's protocol)")
    ax.scatter(v["mean_end_step"], v["energy_distance_upright"], color="C1",
               label="every state before the fall (whole episode)")
    if paper_ed:
      ax.axhspan(-paper_ed[0] - paper_ed[1], -paper_ed[0] + paper_ed[1], color="k", alpha=0.1,
                 label="the paper's energy distance, mean ± std")
    ax.set_xlabel("mean step at which the seed's episodes fell")
    ax.set_ylabel("energy distance")
    actions = "mean" if analysis["deterministic"] else "sampled"
    ax.set_title(f"each seed at the end ({actions} actions, 10 episodes)", fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))  # off the points
    ax.grid(alpha=0.3)
  return _save(fig, plt, directory, f"{common.run_label(spec, directory=directory)}: the energy "
               "distance and the falls "
               "(mean ± std over seeds)")


def print_trend(directory: str, since: float, evaluations: list[str], out: str | None):
  """``alive_trend`` of ``directory``'s metrics.csv and, where ``evaluations`` names eval.json
  files, their ``evaluation_fit``, printed beside the paper's MI and written to ``out`` (default
  ``directory/alive_trend.json``). Returns both (the second None without ``evaluations``)."""
  import csv
  with open(os.path.join(directory, "metrics.csv")) as f:
    trend = alive_trend(list(csv.DictReader(f)), since)
  protocol = evaluation_fit(evaluations) if evaluations else None
  spec = runs.read_spec(directory)
  paper_mi = _paper_row(spec.env, spec.objective).get("eval/mi")
  fit = trend.fit
  result = {"since": trend.since, "last_step": trend.last_step, "quick": dataclasses.asdict(fit),
            "alive_last": trend.alive_last, "alive_rate": trend.alive_rate,
            "policy_entropy": trend.policy_entropy}
  print(f"quick evaluations {trend.since / 1e6:.1f} M to {trend.last_step / 1e6:.1f} M env steps "
        f"per seed, {fit.points} points (seed, evaluation)")
  print(f"MI = {fit.intercept:.3f} + {fit.slope:.3f} x alive share (Pearson r {fit.r:.2f})")
  print(f"mean alive share at the last evaluation {trend.alive_last:.3f}, rising "
        f"{trend.alive_rate:+.4f} per 10 M env steps over the window")
  if trend.policy_entropy:
    print("the policy's entropy (of its squashed actions), mean over seeds: {:.3f} at the window's "
          "first evaluation, {:.3f} at its last".format(*trend.policy_entropy))
  if paper_mi:
    need, steps = fit.alive_for(paper_mi[0]), trend.steps_for(paper_mi[0])
    result.update(paper_mi=paper_mi[0], alive_for_paper_mi=need, steps_for_paper_mi=steps)
    print(f"the fit reaches the paper's MI {paper_mi[0]} at alive share {need:.3f}; the window's "
          f"straight line brings the share there at {steps / 1e6:,.0f} M env steps per seed (an "
          "extrapolation)")
  if protocol:
    fit, pairs = protocol
    result["protocol"] = dict(dataclasses.asdict(fit), evaluations=list(evaluations),
                              alive_mean=float(np.mean([a for a, _ in pairs])))
    print(f"the protocol's evaluations ({len(evaluations)} file(s), {fit.points} seeds): MI = "
          f"{fit.intercept:.3f} + {fit.slope:.3f} x alive share (Pearson r {fit.r:.2f}); their "
          f"mean alive share {result['protocol']['alive_mean']:.3f}")
    if paper_mi:
      result["protocol"]["alive_for_paper_mi"] = fit.alive_for(paper_mi[0])
      print(f"this fit reaches the paper's MI {paper_mi[0]} at alive share "
            f"{fit.alive_for(paper_mi[0]):.3f}")
  out = out or os.path.join(directory, "alive_trend.json")
  common.write_json(out, result)
  print(f"wrote {out}")
  return trend, protocol


def noise_curve(directory: str) -> dict[float, dict[str, list[float]]]:
  """The MI-max fall analyses in ``directory`` by the action noise they were rolled out at (times
  the policy's std: 0 the mean actions, 1 the protocol's sampled actions), each its per-seed
  values. Raises ValueError naming what is missing or wrong: fewer than two scales, two files at
  one scale, a D-min analysis (it has no MI), one with noise on some actions alone."""
  names = ["fall_analysis.json", "fall_analysis_deterministic.json"]
  paths = [os.path.join(directory, n) for n in names] + sorted(
      glob.glob(os.path.join(directory, "fall_analysis_noise_*.json")))
  curve, found = {}, {}
  for path in paths:
    if not os.path.exists(path):
      continue
    with open(path) as f:
      analysis = json.load(f)
    if "mi" not in analysis.get("per_seed", {}):
      raise ValueError(f"{path} holds no MI (a D-min run's analysis?): the noise curve reads "
                       "MI-max analyses")
    if analysis.get("noise_on"):
      raise ValueError(f"{path} sampled the actions of {analysis['noise_on']} alone (--noise-on); "
                       "the noise curve reads analyses with noise on every action")
    scale = (0.0 if analysis.get("deterministic") else 1.0 if analysis.get("noise_scale") is None
             else float(analysis["noise_scale"]))
    if scale in curve:
      raise ValueError(f"{path} and {found[scale]} are both at noise scale {scale:g}")
    curve[scale], found[scale] = analysis["per_seed"], path
  if len(curve) < 2:
    raise ValueError(
        f"{directory}: the noise curve needs the analyses of two noise scales at least; it has "
        f"{', '.join(map(os.path.basename, found.values())) or 'none'} (run `fall_analysis.py "
        "RUN` for scale 1, with --deterministic for 0, with --noise-scale S for S)")
  return dict(sorted(curve.items()))


def _row_in(directory: str) -> tuple[str, str] | None:
  """The (env, objective) of the run whose config is in ``directory`` (a run's config.json, else a
  committed row's single NAME_config.json, read by ``paper_tables.read_config``); None where none
  is. Raises ValueError where that config cannot be read, saying why."""
  prefixes = [os.path.join(directory, "")]
  if not os.path.exists(prefixes[0] + "config.json"):
    prefixes = [p[:-len("config.json")]
                for p in glob.glob(os.path.join(directory, "*_config.json"))]
  if len(prefixes) != 1:
    return None
  config = ablations.paper_tables.read_config(prefixes[0])
  if isinstance(config, str):
    raise ValueError(f"{config}: the noise curve takes its row's name and the paper's MI from it")
  return config["env"], config["objective"]


def noise_table(curves: dict[str, dict]) -> str:
  """``curves`` (label -> ``noise_curve``'s result) as a table: per label and scale, the mean +-
  std over seeds of the alive share, the MI and the MI before the falls."""
  lines = ["| run | noise scale | alive share | MI, every scored state | MI before the falls |",
           "| --- | ---: | ---: | ---: | ---: |"]
  for label, curve in curves.items():
    for scale, values in curve.items():
      cells = [f"{np.mean(values[k]):.3f} +- {np.std(values[k]):.3f}"
               for k in ("alive_share", "mi", "mi_alive")]
      lines.append(f"| {label} | {scale:g} | " + " | ".join(cells) + " |")
  return "\n".join(lines)


def draw_noise_curves(path: str, curves: dict[str, dict],
                      row: tuple[str, str] | None = None) -> str:
  """``path``, a PNG of ``curves`` (label -> ``noise_curve``'s result): the alive share, and the
  MI of every scored state (solid) and of the states before the falls (dashed), against the
  action noise, mean +- std over seeds; ``row``, (env, objective) where known: the title names it
  and the paper's MI (mean +- std) is drawn where the paper has one."""
  paper_mi = _paper_row(*row).get("eval/mi") if row else None
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
  for i, (label, curve) in enumerate(curves.items()):
    x = np.array(list(curve))
    for ax, key, style, name in ((left, "alive_share", "-o", label),
                                 (right, "mi", "-o", f"{label}: every scored state"),
                                 (right, "mi_alive", "--", f"{label}: states before the fall")):
      mean = np.array([np.mean(v[key]) for v in curve.values()])
      std = np.array([np.std(v[key]) for v in curve.values()])
      ax.plot(x, mean, style, color=f"C{i}", label=name, ms=4)
      ax.fill_between(x, mean - std, mean + std, color=f"C{i}", alpha=0.15)
  if paper_mi:
    right.axhspan(paper_mi[0] - paper_mi[1], paper_mi[0] + paper_mi[1], color="k", alpha=0.1,
                  label=f"the paper's MI, {paper_mi[0]} ± {paper_mi[1]}")
  for ax in (left, right):
    ax.axvline(1.0, color="k", ls=":", lw=1)
    ax.set_xlabel("action noise, times the policy's std (0: mean actions; 1: the protocol)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
  left.set_ylim(0, 1)
  left.set_ylabel("alive share of the scored states")
  left.set_title("scored states taken before the fall")
  right.set_ylabel("MI (nats)")
  right.set_title("MI(s, z) of the skills")
  fig.suptitle((f"{row[1]} on {row[0]}: " if row else "") + "how much action noise the bodies "
               "stand, and the MI it leaves (mean ± std over seeds; the protocol samples at 1)",
               fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=110)
  plt.close(fig)
  return path


def joint_noise(directory: str) -> list[tuple[str, int | None, dict]]:
  """The MI-max analyses in ``directory`` by the actions that carried the noise: the mean actions
  (``fall_analysis_deterministic.json``: none), each ``--noise-on`` analysis at scale 1
  (``fall_analysis_on_*.json``, fewest noisy actions first) and the protocol's sampled actions
  (``fall_analysis.json``: every action), as (label, noisy actions, per-seed values). The seeds
  share their keys, latents and draws (``common.picked_seeds``), so the rows pair by seed.
  Raises ValueError where the mean-action or the protocol's analysis is missing or holds no MI,
  or an analysis' seeds differ from theirs."""
  def read(name: str) -> dict:
    path = os.path.join(directory, name)
    if not os.path.exists(path):
      raise ValueError(f"{directory}: the noise by joints needs {name} beside the --noise-on "
                       "analyses (fall_analysis.py RUN, and with --deterministic)")
    with open(path) as f:
      return json.load(f)

  mean, protocol = read("fall_analysis_deterministic.json"), read("fall_analysis.json")
  if "mi" not in protocol.get("per_seed", {}):
    raise ValueError(f"{directory}/fall_analysis.json holds no MI (a D-min run's analysis?): the "
                     "noise by joints reads MI-max analyses")
  seeds = protocol["seeds"]
  middle = []
  for path in sorted(glob.glob(os.path.join(directory, "fall_analysis_on_*.json"))):
    with open(path) as f:
      analysis = json.load(f)
    if analysis.get("noise_scale") not in (None, 1.0):
      continue  # a --noise-on analysis at another scale is not one of these rows
    label = ", ".join(pattern.strip("*") for pattern in analysis["noise_on"])
    middle.append((label, len(analysis["noisy_joints"]), analysis, path))
  if not middle:
    raise ValueError(f"{directory} holds no fall_analysis_on_*.json at scale 1 (fall_analysis.py "
                     "RUN --noise-on JOINT ...)")
  rows = [("none (the mean actions)", 0, mean, ""), *sorted(middle, key=lambda r: (r[1], r[0])),
          ("every action (the protocol)", None, protocol, "")]
  out = []
  for label, count, analysis, path in rows:
    if analysis["seeds"] != seeds:
      raise ValueError(f"{path or label}: seeds {analysis['seeds']}, the protocol's analysis "
                       f"{seeds}: the rows pair by seed")
    out.append((label, count, analysis["per_seed"]))
  return out


def joint_noise_table(rows: list[tuple[str, int | None, dict]]) -> str:
  """``joint_noise``'s rows as a table: the alive share, its change from the mean actions with the
  paired t-test's p over seeds, the MI and the MI before the falls (mean +- std over seeds)."""
  from scipy import stats
  base = rows[0][2]["alive_share"]
  lines = ["| noise on | actions | alive share | change, paired p | MI | MI before the falls |",
           "| --- | ---: | ---: | ---: | ---: | ---: |"]
  for i, (label, count, values) in enumerate(rows):
    cell = lambda k: f"{np.mean(values[k]):.3f} +- {np.std(values[k]):.3f}"
    change = ("" if i == 0 else
              f"{np.mean(values['alive_share']) - np.mean(base):+.3f}, "
              f"{stats.ttest_rel(values['alive_share'], base).pvalue:.3f}")
    lines.append(f"| {label} | {'all' if count is None else count} | {cell('alive_share')} | "
                 f"{change} | {cell('mi')} | {cell('mi_alive')} |")
  return "\n".join(lines)


def draw_joint_noise(path: str, rows: list[tuple[str, int | None, dict]],
                     row: tuple[str, str] | None = None) -> str:
  """``path``, a PNG of ``joint_noise``'s rows: horizontal bars of the alive share and of the MI
  (every scored state; a tick at the states before the falls), mean +- std over seeds, beside the
  paper's MI where ``row`` (env, objective) has one."""
  paper_mi = _paper_row(*row).get("eval/mi") if row else None
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  y = np.arange(len(rows))[::-1]
  labels = [f"{label} ({'all' if count is None else count})" for label, count, _ in rows]
  fig, (left, right) = plt.subplots(1, 2, figsize=(11, 0.45 * len(rows) + 1.6), sharey=True)
  colors = ["C2"] + ["C0"] * (len(rows) - 2) + ["C3"]
  for ax, key in ((left, "alive_share"), (right, "mi")):
    mean = [np.mean(v[key]) for _, _, v in rows]
    std = [np.std(v[key]) for _, _, v in rows]
    ax.barh(y, mean, xerr=std, color=colors, alpha=0.8, capsize=3)
    ax.grid(axis="x", alpha=0.3)
  right.plot([np.mean(v["mi_alive"]) for _, _, v in rows], y, "k|", ms=14, mew=2,
             label="MI of the states before the falls")
  if paper_mi:
    right.axvspan(paper_mi[0] - paper_mi[1], paper_mi[0] + paper_mi[1], color="k", alpha=0.1,
                  label=f"the paper's MI, {paper_mi[0]} ± {paper_mi[1]}")
  right.legend(fontsize=7, loc="lower right")
  left.set_yticks(y, labels, fontsize=8)
  left.set_xlim(0, 1)
  left.set_xlabel("alive share of the scored states")
  right.set_xlabel("MI (nats), every scored state")
  fig.suptitle((f"{row[1]} on {row[0]}: " if row else "") + "the policy's action noise on some "
               "joints alone, the mean action on the rest (number of noisy actions in brackets; "
               "mean ± std over seeds)", fontsize=9)
  fig.tight_layout()
  fig.savefig(path, dpi=110)
  plt.close(fig)
  return path


# The options of a rollout, which the modes that only read what is written refuse.
ROLLOUT_OPTIONS = ("--seeds", "--deterministic", "--noise-scale", "--noise-on", "--blind",
                   "--draws")


def _refuse(parser, args, why: str, flags: tuple[str, ...]) -> None:
  """``parser.error`` naming those of ``flags`` that were given (set off their defaults: a
  ``--noise-scale 0`` is given), where any was."""
  dests = {flag: flag[2:].replace("-", "_") for flag in flags}
  given = [flag for flag, dest in dests.items()
           if getattr(args, dest) != parser.get_default(dest)]
  if given:
    parser.error(f"{why}: {', '.join(given)} {'is' if len(given) == 1 else 'are'} not its")


def _table_and_figure(parser, args, read, table, draw, name: str) -> int:
  """The read-only modes' end: ``read()`` the analyses and the row of ``args.run``'s config
  (errors through ``parser``), print ``table`` of them and ``draw`` them to ``--out`` or
  RUN_DIR/``name``."""
  try:
    found, row = read(), _row_in(args.run)
  except (OSError, ValueError) as e:
    parser.error(str(e))
  print(table(found))
  out = args.out or os.path.join(args.run, name)
  print(f"wrote {draw(out, found, row)}")
  return 0


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  common.add_analysis_arguments(parser, "a finished MI-max or D-min run directory (config.json "
                                "and checkpoint)")
  parser.add_argument("--noise-scale", type=float, default=None,
                      help="sample at this multiple of the policy's std (a diagnostic)")
  parser.add_argument("--noise-on", nargs="+", default=None, metavar="JOINT",
                      help="sample only the actions of the joints matching these patterns "
                           "(fnmatch, e.g. '*hip*' '*knee*'; at --noise-scale, default 1), the "
                           "mean action on the others (a diagnostic)")
  parser.add_argument("--blind", nargs="+", default=None, metavar="PART",
                      help="hold the observation's parts matching these patterns (fnmatch on "
                           "obs_layout's names, e.g. actuator_force 'contact_*') at the running "
                           "means the policy normalises with (a diagnostic)")
  parser.add_argument("--draws", type=int, default=None,
                      help="random subsets for the control (default 5)")
  parser.add_argument("--plot", action="store_true",
                      help="only draw falls.png from metrics.csv and fall_analysis.json")
  parser.add_argument("--trend", action="store_true",
                      help="only fit the quick evaluations' MI against their alive share")
  parser.add_argument("--since", type=float, default=0.0,
                      help="with --trend: the first env step per seed of the window (default 0)")
  parser.add_argument("--evals", nargs="+", default=[], metavar="EVAL_JSON",
                      help="with --trend: also fit the seeds of these eval.json files (or run "
                           "directories holding one)")
  parser.add_argument("--noise-curve", action="store_true",
                      help="only draw the alive share and MI against the action noise from the "
                           "analyses already written")
  parser.add_argument("--by-joints", action="store_true",
                      help="only tabulate and draw the --noise-on analyses already written, "
                           "between the mean actions and the protocol's (joint_noise.png)")
  parser.add_argument("--against", nargs="+", default=[], metavar="DIR",
                      help="with --noise-curve: other directories of analyses to draw beside")
  parser.add_argument("--labels", nargs="+", default=None,
                      help="with --noise-curve: a name per directory, RUN_DIR's first")
  args = parser.parse_args(argv)
  if (args.against or args.labels) and not args.noise_curve:
    parser.error("--against and --labels are --noise-curve's; give --noise-curve with them")
  if args.by_joints:
    _refuse(parser, args, "--by-joints reads the analyses already written and rolls nothing out",
            ("--noise-curve", "--plot", "--trend", "--since", "--evals", *ROLLOUT_OPTIONS))
    return _table_and_figure(parser, args, lambda: joint_noise(args.run), joint_noise_table,
                             draw_joint_noise, "joint_noise.png")
  if args.noise_curve:
    _refuse(parser, args, "--noise-curve reads the analyses already written and rolls nothing out",
            ("--plot", "--trend", "--since", "--evals", *ROLLOUT_OPTIONS))
    directories = [args.run, *args.against]
    labels = args.labels or [os.path.basename(os.path.normpath(d)) for d in directories]
    if len(labels) != len(directories):
      parser.error(f"--labels gives {len(labels)} names for {len(directories)} directories "
                   "(RUN_DIR and each --against)")
    if len(set(labels)) != len(labels):
      parser.error(f"each line needs a name of its own, and these are not: {labels} (give "
                   "--labels, one per directory)")
    return _table_and_figure(
        parser, args, lambda: {label: noise_curve(d) for label, d in zip(labels, directories)},
        noise_table, draw_noise_curves, "noise_curve.png")
  if (args.since or args.evals) and not args.trend:
    parser.error("--since and --evals are --trend's; give --trend with them")
  if args.plot or args.trend:
    _refuse(parser, args, "--plot and --trend read metrics.csv and roll nothing out",
            ROLLOUT_OPTIONS)
  trend = protocol = None
  if args.trend:
    try:
      trend, protocol = print_trend(args.run, args.since, args.evals, args.out)
    except (OSError, ValueError) as e:
      parser.error(str(e))
  if args.plot:
    print(f"wrote {plot(args.run, trend, protocol)}")
  if args.plot or args.trend:
    return 0
  run = runs.load_run(args.run)
  dmin = isinstance(run.objective.spec, DminSpec)
  if not (dmin or isinstance(run.objective.spec, MimaxSpec)):
    parser.error(f"{args.run}: {run.spec.objective} is neither an MI-max nor a D-min objective; "
                 "this analysis reads MI or the energy distance")
  n = len(run.spec.seeds)
  try:
    picked = common.seed_positions(args.seeds, n)
  except ValueError as e:
    parser.error(str(e))
  if args.noise_scale is not None and (args.deterministic or args.noise_scale < 0):
    parser.error("--noise-scale takes a number >= 0 and not --deterministic (which is scale 0)")
  if args.noise_on and args.deterministic:
    parser.error("--noise-on samples the actions of the joints it names; --deterministic samples "
                 "none: give one of them")
  noise_on = None
  if args.noise_on:
    names = common.action_names(run.env)
    try:
      noise_on = noisy_actions(names, args.noise_on)
    except ValueError as e:
      parser.error(str(e))
  blind = None
  if args.blind:
    try:
      blind, blind_parts = blind_indices(envs.unwrap(run.env).obs_layout, args.blind)
    except ValueError as e:
      parser.error(str(e))
    if not np.all(np.asarray(run.params.normalizer.count) > 0):
      parser.error(f"--blind holds parts at the running means the policy normalises its input "
                   f"with, and {args.run} kept none (trained without normalize_observations)")
  args.draws = 5 if args.draws is None else args.draws
  if args.draws < 1:
    parser.error("--draws must be at least 1")
  params, keys = common.picked_seeds(run, picked, 1)
  if dmin:
    one = lambda p, k: analyse_dmin(run, p, k, deterministic=args.deterministic,
                                    noise_scale=args.noise_scale, noise_on=noise_on, blind=blind)
  else:
    one = lambda p, k: analyse(run, p, k, deterministic=args.deterministic, draws=args.draws,
                               noise_scale=args.noise_scale, noise_on=noise_on, blind=blind)
  values = {k: np.asarray(v).tolist() for k, v in jax.jit(jax.vmap(one))(params, keys).items()}
  result = {"run": os.path.abspath(args.run), "seeds": [run.spec.seeds[p] for p in picked],
            "env_steps": run.env_steps,  # the checkpoint's: a run under training is analysed too
            "deterministic": args.deterministic, "noise_scale": args.noise_scale,
            "draws": args.draws, "per_seed": values}
  if noise_on is not None:
    result["noise_on"] = list(args.noise_on)
    result["noisy_joints"] = [n for n, w in zip(names, noise_on) if w]
  if blind is not None:
    result["blind"], result["blind_parts"] = list(args.blind), blind_parts
  if dmin:
    spec = run.objective.spec
    target = jnp.asarray(spec.target.samples)[:, :len(spec.obs_indices)]
    result["energy_distance_at_rest"] = float(
        metrics.energy_distance(jnp.zeros((500, target.shape[1])), target))
  if len(picked) > 2:
    if dmin:
      result["corr_energy_distance_mean_end_step"] = float(
          np.corrcoef(values["energy_distance"], values["mean_end_step"])[0, 1])
    else:
      result["corr_mi_alive_share"] = float(np.corrcoef(values["mi"], values["alive_share"])[0, 1])
  name = ("fall_analysis_deterministic.json" if args.deterministic
          else noise_on_name(args.noise_on, args.noise_scale) if args.noise_on
          else "fall_analysis.json" if args.noise_scale is None
          else f"fall_analysis_noise_{args.noise_scale:g}.json")
  if blind is not None:
    name = blind_name(args.blind, name)
  out = args.out or os.path.join(args.run, name)
  common.write_json(out, result)
  actions = ("mean" if args.deterministic else "sampled" if args.noise_scale is None
             else f"{args.noise_scale:g} x std sampled")
  if noise_on is not None:
    actions += f" on {', '.join(result['noisy_joints'])} (the mean on the others)"
  blind_to = ("" if blind is None
              else f", the policy blind to {', '.join(blind_parts)} (held at their running means)")
  print(f"{run.spec.objective} on {run.spec.env}, seeds {result['seeds']}, {actions} actions"
        f"{blind_to}")
  print("| metric | mean +- std over seeds |\n| --- | ---: |")
  for k, v in values.items():
    print(f"| {k} | {np.mean(v):.3f} +- {np.std(v):.3f} |")
  if "corr_mi_alive_share" in result:
    print(f"Pearson r over seeds, MI against alive share: {result['corr_mi_alive_share']:.2f}")
  if "energy_distance_at_rest" in result:
    print(f"energy distance of a body at rest: {result['energy_distance_at_rest']:.3f}")
  if "corr_energy_distance_mean_end_step" in result:
    print("Pearson r over seeds, energy distance against the mean end of an episode: "
          f"{result['corr_energy_distance_mean_end_step']:.2f}")
  print(f"wrote {out}")
  return 0


if __name__ == "__main__":
  raise SystemExit(main())
