"""What can a body do under open-loop gaits? A cross-entropy search over sinusoid gaits, on blx's
body (C MuJoCo, float64, the env's own MJCF and torque cut) or on Brax v1's physics, one budget.

    python benchmarks/gait_search.py --sim blx [--body ant] [--edits JSON] [--no-cut] [--seeds 4]
    python benchmarks/gait_search.py --sim brax --brax-config ant_v006.txt   # needs brax 0.12.1
    python benchmarks/gait_search.py --sim blx --body halfcheetah --score swing --target 1.5 \\
        --edits '{"global_options.timestep": 0.00625, "global_options.substeps": 8}'
    python benchmarks/gait_search.py --sim brax --body halfcheetah --score swing --target 1.5 \\
        --brax-config halfcheetah_v006.txt
    python benchmarks/gait_search.py --sim brax --body halfcheetah --drift 96 \\
        --brax-config halfcheetah_v006.txt
    python benchmarks/gait_search.py --sim blx --body pro_ant_run --env-param num_legs=3
    python benchmarks/gait_search.py --sim brax --body pro_ant_run --env-param num_legs=3
    python benchmarks/gait_search.py --plot-legs legs.png SEARCH.json ... [ROOT_VELOCITY.json ...]

A gait is a_j(t) = clip(amp_j sin(2 pi f t + phase_j) + bias_j, -1, 1) for the body's n motors
(3n + 1 numbers: 25 for the ant, 19 for the halfcheetah). Each episode runs 6 s, 120 control
steps of 0.05 s (a body whose control step is another, as ``pro_ant_run``'s 0.02 s, as many as
make 6 s); the first second is a warm-up. Each seed runs ``--iters`` rounds of 96 samples,
refitting a diagonal Gaussian to the best 12. Printed per seed: the best score (optimistic: gaits
are chaotic, so the best of 96 is partly luck) and the elite mean of the last round (the figure
to compare).

Scores (higher is better):

* ``speed``: the torso's planar speed over the 5 s after the warm-up (m/s); the ant scores 0 if
  its torso leaves z in [0.2, 1] (Brax v1's ant termination; the halfcheetah has none), and
  ``pro_ant_run`` (``--env-param num_legs=N``, the paper's procedural ant) also if it turns upside
  down (the original's upright rule): the fastest it could run, beside the speed its run reward
  asks for (4 m/s).
* ``energy`` (ant): can a gait spread the torso's xy velocity over GAIL's bimodal target (modes
  (+-4, 0) m/s, std 0.8; the paper's D-min rows)? Minus the energy distance between the torso's xy
  velocity at every step after the warm-up and the target's 250 samples (velocities spread like one
  of the two modes score about -2.8, standing still -3.4).
* ``swing``: how steadily can the body hold the forward speed ``--target``? Minus the root mean
  square of (torso x velocity - target) over the control steps after the warm-up, the velocity read
  once per control step as the MI-max rows' feature is. It is the spread that one latent's or one
  skill's speeds would have if the policy ran this gait: the within-episode part of H(s|z). For the
  last round's 12 best gaits the JSON also keeps the mean and the std of their speed.

``--drift POSES`` searches nothing: it rolls out POSES random constant actions (each motor's action
drawn from [-1, 1] and held) and reports how fast the torso still moves along x over the last
2.5 s. On sound physics a body held in a pose comes to rest; one that keeps moving is carried by
the simulator.

``--held POSES --noise SIGMA`` (halfcheetah) scores skills that hold still: POSES held poses, each
with Gaussian action noise of std SIGMA every step, over 1000-step episodes, and their H(s) by the
rows' protocol (the x velocity over the last 500 steps, 1000 bins over [-5, 5]).

``--sim brax`` builds a Brax v1 system from a Brax config in text format (``_SYSTEM_CONFIG`` of
``brax/envs/ant.py`` or ``halfcheetah.py`` at v0.0.6, the physics of commit 2821f78 behind the
paper) with ``dynamics_mode: "legacy_spring"``: Brax 0.12.1's ``brax.v1``, with the two jax aliases
the fact sheet lists (``shared/reference/brax-v1-bodies.md`` section 10). legacy_spring multiplies
the two colliders' friction, so the global friction is replaced by its square root (the cheetah's
0.4 stays 0.4 per contact; the ant's 1 is unchanged). What still differs from the paper's physics
is v0.0.6's orientation update at twice the angular velocity, fixed in v0.0.7. ``--sim brax --body
pro_ant_run`` needs no config: it builds the paper's procedural ant of ``--env-param num_legs=N``
legs (``brax_pro_ant_config``: Braxlines' pro_ant at 2821f78 on its composer's ground and global
options, at the run's 0.02 s control step of 16 substeps), so one search compares leg counts on
the paper's physics as ``--sim blx`` does on blx's.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

STEPS, WARM, DT = 120, 20, 0.05
POPULATION, ELITE = 96, 12
BODIES = ("ant", "halfcheetah", "pro_ant_run")
SCORES = ("speed", "energy", "swing")
BRAX_SETTABLE = ("substeps", "dt", "friction", "angular_damping", "baumgarte_erp")


def gait_actions(params, t, xp=np, dt=DT):
  """Actions ``[..., n]`` of gaits ``params [..., 3n + 1]`` at env step ``t`` of ``dt`` seconds;
  ``xp`` is numpy (blx's rollouts) or jax.numpy (Brax v1's, traced)."""
  n = (params.shape[-1] - 1) // 3
  amp, phase = xp.clip(params[..., :n], 0, 1.5), params[..., n:2 * n]
  bias, freq = xp.clip(params[..., 2 * n:3 * n], -1, 1), xp.clip(params[..., 3 * n:], 0.5, 4.0)
  return xp.clip(amp * xp.sin(2 * xp.pi * freq * t * dt + phase) + bias, -1, 1)


def cross_entropy(score, num_motors: int, seed: int, iters: int) -> dict:
  """Maximises ``score(params [P, 3n + 1]) -> [P]``: the best score and its params, the elite mean
  of every round, and the last round's elite params (best first)."""
  rng = np.random.default_rng(seed)
  n = num_motors
  mean = np.concatenate([np.full(n, 0.8), np.zeros(2 * n), [2.0]])
  std = np.concatenate([np.full(n, 0.4), np.full(n, np.pi), np.full(n, 0.3), [1.0]])
  best, best_params, elite_means, elite = -np.inf, None, [], None
  for _ in range(iters):
    params = mean + std * rng.standard_normal((POPULATION, 3 * n + 1))
    scores = score(params)
    order = np.argsort(-scores)[:ELITE]
    if scores[order[0]] > best:
      best, best_params = float(scores[order[0]]), params[order[0]].copy()
    mean, std = params[order].mean(0), params[order].std(0) + 0.02
    elite_means.append(float(scores[order].mean()))
    elite = params[order]
  return dict(best=best, best_params=best_params, elite_means=elite_means, elite_params=elite)


@functools.lru_cache(maxsize=None)
def _gail_target() -> tuple[np.ndarray, float]:
  """GAIL's target samples ``[250, 2]`` and their mean pairwise distance (drawn once)."""
  from blx.objectives.targets import multimode_gaussian
  y = np.asarray(multimode_gaussian(2, scale=8.0, dim=2).samples, np.float64)
  return y, float(np.linalg.norm(y[:, None] - y[None], axis=-1).mean())


def energy_score(velocities: np.ndarray, alive: np.ndarray) -> np.ndarray:
  """Minus the energy distance of each gait's velocities ``[P, T, 2]`` to GAIL's target; -10 for a
  gait whose torso left the healthy heights."""
  y, yy = _gail_target()
  out = np.full(len(velocities), -10.0)
  for i, x in enumerate(velocities):
    if alive[i] and np.isfinite(x).all():
      xy = np.linalg.norm(x[:, None] - y[None], axis=-1).mean()
      xx = np.linalg.norm(x[:, None] - x[None], axis=-1).mean()
      out[i] = -(2 * xy - xx - yy)
  return out


def swing_score(velocities: np.ndarray, alive: np.ndarray, target: float) -> np.ndarray:
  """Minus the RMS of (x velocity - ``target``) over each gait's steps ``[P, T, D]``; -100 for a
  gait that was cut short or blew up."""
  vx = velocities[..., 0]
  rms = np.sqrt(np.mean((vx - target) ** 2, axis=1))
  return np.where(alive & np.isfinite(rms), -rms, -100.0)


def scores_of(kind: str, rollout, target: float | None):
  """``params -> [P]`` for score ``kind``, from ``rollout(params) -> (velocities [P, T, D] after the
  warm-up, planar speed [P], alive [P])``."""
  def score(params):
    velocities, speed, alive = rollout(params)
    if kind == "energy":
      return energy_score(velocities, alive)
    if kind == "swing":
      return swing_score(velocities, alive, target)
    return np.where(alive, speed, 0.0)
  return score


def upside_down(quat) -> bool:
  """Whether a free body of orientation ``quat`` (w, x, y, z) has its z axis pointing down."""
  return 1 - 2 * (quat[1] ** 2 + quat[2] ** 2) < 0


def blx_rollout(body: str, edits: dict | None, cut: bool, env_params: dict | None = None):
  """``params -> (velocities, speed, alive)`` on blx's ``body`` (C MuJoCo, float64), created with
  ``env_params`` (e.g. ``{"num_legs": 3}`` for ``pro_ant_run``). At a control step ``dt`` other
  than 0.05 s, an episode of ``steps`` is ``steps * 0.05 / dt`` control steps, its warm-up too."""
  import mujoco

  from blx import envs
  env = envs.unwrap(envs.create(body, edits=edits, **(env_params or {})))
  m, torque_cut, dt = env.mj_model, env.torque_cut, float(env.dt)
  # the root's planar slide dofs (the halfcheetah's rootx) or the free joint's x, y
  free = m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
  dofs = np.array([0, 1] if free else [0])
  height = 2 if free else None   # the ant's torso z; the halfcheetah never terminates
  upright = body == "pro_ant_run"  # the original's procedural ant also ends upside down
  per_step = DT / dt

  def ctrl(action, qpos):
    action = action.astype(np.float64)
    if cut and len(torque_cut.actuators):
      angle = qpos[torque_cut.qpos_adr]
      action[torque_cut.actuators] *= (angle >= torque_cut.low) & (angle <= torque_cut.high)
    return action

  def rollout(params, steps=STEPS, noise=None):
    steps, warm = int(round(steps * per_step)), int(round(WARM * per_step))
    velocities = np.zeros((len(params), steps - warm, len(dofs)))
    speed, alive = np.zeros(len(params)), np.zeros(len(params), bool)
    for i in range(len(params)):
      d = mujoco.MjData(m)
      d.qpos[:] = env.init_qpos
      mujoco.mj_forward(m, d)
      for t in range(steps):
        if t == warm:
          start = d.qpos[dofs].copy()
        action = gait_actions(params[i:i + 1], t, dt=dt)[0]
        if noise is not None:
          action = np.clip(action + noise[t, i], -1, 1)
        for _ in range(env.substeps):
          d.ctrl[:] = ctrl(action, d.qpos)
          mujoco.mj_step(m, d)
        if not np.isfinite(d.qpos).all() or (height is not None
                                             and not 0.2 <= d.qpos[height] <= 1.0) or (
            upright and upside_down(d.qpos[3:7])):
          break
        if t >= warm:
          velocities[i, t - warm] = d.qvel[dofs]
      else:
        alive[i] = True
        speed[i] = np.linalg.norm(d.qpos[dofs] - start) / ((steps - warm) * dt)
    return velocities, speed, alive

  return rollout, m.nu


def parse_brax_sets(pairs: list[str]) -> dict[str, float]:
  """``["substeps=64", ...]`` -> ``{"substeps": 64.0}``; a clear error for anything else."""
  out = {}
  for pair in pairs:
    field, _, value = pair.partition("=")
    if field not in BRAX_SETTABLE:
      raise ValueError(f"--brax-set {pair!r}: the field must be one of {', '.join(BRAX_SETTABLE)}")
    try:
      out[field] = float(value)
    except ValueError:
      raise ValueError(f"--brax-set {pair!r}: the value must be a number") from None
  return out


def brax_pro_ant_config(num_legs: int, strength: float | None = None) -> str:
  """A Brax v1 config (text format) of ``pro_ant_run``'s world as the paper ran it: the procedural
  ant of ``num_legs`` legs on the composer's ground, the composer's global options with the run's
  0.02 s control step of 16 substeps. The torso: a 10 kg capsule of radius 0.25 and length 0.5
  with one end cap. Leg i at theta = 2 pi i / N: a thigh capsule (r 0.08, length 0.443) on a hip
  0.301 m out along theta, a hinge of +-30 deg about the vertical; a shin capsule (r 0.08, length
  0.726, one end cap) on a knee across the leg, 30..70 deg; every link 1 kg with inertia 1; every
  joint of stiffness 5000 and angular damping 35, driven by a torque actuator of ``strength``
  (None: the paper's 300). Every body of the ant collides with the ground, and nothing else
  collides."""
  # the facts as blx's pro_ant (the same body as MJCF) takes them
  from blx.envs import brax_bodies as b
  from blx.envs.brax_bodies import MAX_LEGS, MIN_LEGS
  strength = b.PRO_ANT_STRENGTH if strength is None else strength
  if not isinstance(num_legs, int) or isinstance(num_legs, bool) or not (
      MIN_LEGS <= num_legs <= MAX_LEGS):
    raise ValueError(f"num_legs={num_legs!r}: the procedural ant takes {MIN_LEGS}..{MAX_LEGS} legs")
  lines = ['bodies { name: "torso" colliders { capsule { radius: 0.25 length: 0.5 end: 1 } }',
           '  inertia { x: 1.0 y: 1.0 z: 1.0 } mass: 10 }']
  colliders = ["torso"]
  for i in range(num_legs):
    theta = 2 * np.pi * i / num_legs
    thigh, shin = f"thigh_{i}", f"shin_{i}"
    lines += [
        f'bodies {{ name: "{thigh}" colliders {{ rotation {{ x: 90 y: -90 }} capsule {{ radius: '
        f'{b.PRO_ANT_RADIUS} length: {b.PRO_ANT_THIGH_LENGTH} }} }}',
        '  inertia { x: 1.0 y: 1.0 z: 1.0 } mass: 1 }',
        f'bodies {{ name: "{shin}" colliders {{ rotation {{ x: 90 y: -90 }} capsule {{ radius: '
        f'{b.PRO_ANT_RADIUS} length: {b.PRO_ANT_SHIN_LENGTH} end: -1 }} }}',
        '  inertia { x: 1.0 y: 1.0 z: 1.0 } mass: 1 }',
        f'joints {{ name: "hip_{i}" parent: "torso" child: "{thigh}"',
        f'  parent_offset {{ x: {float(b.PRO_ANT_HIP * np.cos(theta))!r} '
        f'y: {float(b.PRO_ANT_HIP * np.sin(theta))!r} }} child_offset {{ }}',
        f'  stiffness: 5000.0 angular_damping: {b.ANT_DAMPING!r} '
        'angle_limit { min: -30.0 max: 30.0 }',
        f'  rotation {{ y: -90 }} reference_rotation {{ z: {float(np.degrees(theta))!r} }} }}',
        f'joints {{ name: "knee_{i}" parent: "{thigh}" child: "{shin}"',
        f'  parent_offset {{ x: {b.PRO_ANT_KNEE!r} }} child_offset {{ x: {-b.PRO_ANT_SHIN!r} }}',
        f'  stiffness: 5000.0 angular_damping: {b.ANT_DAMPING!r} rotation {{ z: 90 }} '
        'angle_limit { min: 30.0 max: 70.0 } }']
    lines += [f'actuators {{ name: "{j}_{i}" joint: "{j}_{i}" strength: {float(strength)!r} '
              'torque { } }' for j in ("hip", "knee")]
    colliders += [thigh, shin]
  lines += ['bodies { name: "Ground" colliders { plane { } } inertia { x: 1.0 y: 1.0 z: 1.0 }',
            '  mass: 1 frozen { all: true } }']
  lines += [f'collide_include {{ first: "{c}" second: "Ground" }}' for c in colliders]
  lines += ["friction: 1.0", "gravity { z: -9.8 }", "angular_damping: -0.05",
            "baumgarte_erp: 0.1", "dt: 0.02", "substeps: 16"]
  return "\n".join(lines) + "\n"


def brax_rollout(config_path: str | None, body: str, sets: dict[str, float] | None = None,
                 text: str | None = None):
  """``params -> (velocities, speed, alive)`` on Brax v1's physics (brax 0.12.1, legacy_spring),
  from the config in text format at ``config_path`` (or ``text`` itself), with its top-level
  ``sets`` (e.g. ``{"substeps": 64}``) replaced first. At a control step ``dt`` other than 0.05 s,
  an episode and its warm-up are as many steps as make the same seconds, as on blx."""
  import jax
  import jax.numpy as jnp
  from jax._src import core as jax_core
  from jax._src.interpreters import batching
  jax.interpreters.batching.BatchTracer = batching.BatchTracer
  if not hasattr(jax.core, "unsafe_am_i_under_a_jit_DO_NOT_USE"):
    jax.core.unsafe_am_i_under_a_jit_DO_NOT_USE = jax_core.unsafe_am_i_under_a_jit
  from brax import v1 as brax
  from google.protobuf import text_format

  if text is None:
    with open(config_path) as f:
      text = f.read()
  config = text_format.Parse(text + '\ndynamics_mode: "legacy_spring"\n', brax.Config())
  for field, value in (sets or {}).items():
    setattr(config, field, type(getattr(config, field))(value))
  config.friction = float(np.sqrt(config.friction))   # legacy_spring multiplies the pair's
  system = brax.System(config)
  qp0 = system.default_qp()
  n, dims = system.num_actuators, (1 if body == "halfcheetah" else 2)
  dt = float(config.dt)
  per_step = DT / dt

  def one(params, noise, warm):
    def step(carry, xs):
      t, eps = xs
      qp, alive, start = carry
      action = jnp.clip(gait_actions(params, t, jnp, dt=dt) + eps, -1, 1)
      qp, _ = system.step(qp, action)
      alive &= jnp.all(jnp.isfinite(qp.pos[0]))
      if body != "halfcheetah":
        alive &= (qp.pos[0, 2] >= 0.2) & (qp.pos[0, 2] <= 1.0)
      if body == "pro_ant_run":
        alive &= ~upside_down(qp.rot[0])
      start = jnp.where(t == warm - 1, qp.pos[0, :dims], start)
      return (qp, alive, start), qp.vel[0, :dims]

    steps = noise.shape[0]
    (qp, alive, start), vel = jax.lax.scan(step, (qp0, jnp.array(True), qp0.pos[0, :dims]),
                                           (jnp.arange(steps), noise))
    speed = jnp.linalg.norm(qp.pos[0, :dims] - start) / ((steps - warm) * dt)
    return vel[warm:], speed, alive

  @functools.lru_cache(maxsize=None)
  def batched(warm):  # noise [steps, P, n]; the warm-up's length fixes the velocities' shape
    return jax.jit(jax.vmap(functools.partial(one, warm=warm), in_axes=(0, 1)))

  def rollout(params, steps=STEPS, noise=None):
    steps, warm = int(round(steps * per_step)), int(round(WARM * per_step))
    if noise is None:
      noise = np.zeros((steps, len(params), n))
    vel, speed, alive = batched(warm)(jnp.asarray(params, jnp.float32),
                                      jnp.asarray(noise, jnp.float32))
    return (np.asarray(vel, np.float64), np.asarray(speed, np.float64),
            np.asarray(alive, bool))

  return rollout, n


def held_poses(rng: np.random.Generator, poses: int, num_motors: int) -> np.ndarray:
  """Gaits ``[poses, 3n + 1]`` of amplitude 0: constant actions drawn uniformly from [-1, 1]^n."""
  params = np.zeros((poses, 3 * num_motors + 1))
  params[:, 2 * num_motors:3 * num_motors] = rng.uniform(-1, 1, (poses, num_motors))
  params[:, 3 * num_motors] = 1.0
  return params


def constant_action_drift(rollout, num_motors: int, poses: int, seed: int = 0) -> dict:
  """Rolls out ``poses`` constant actions drawn uniformly from [-1, 1]^n (no gait: amplitude 0) and
  returns how fast each torso still moves along x over the episode's last 2.5 s (``|mean vx|``,
  m/s). A body at rest under a constant torque does no work, so on sound physics it comes to a
  stop; a body that keeps moving is driven by the simulator, not by a gait."""
  params = held_poses(np.random.default_rng(seed), poses, num_motors)
  velocities, _, alive = rollout(params)
  drift = np.abs(velocities[:, -int(round(2.5 / DT)):, 0].mean(1))
  return dict(drift=drift.tolist(), alive=alive.tolist(), median=float(np.median(drift)),
              share_above_0_1=float(np.mean(drift > 0.1)), max=float(drift.max()))


def held_pose_entropy(rollout, num_motors: int, poses: int, sigma: float, seed: int = 0,
                      steps: int = 1000, last: int = 500, scale: float = 5.0) -> dict:
  """H(s) of skills that hold still: ``poses`` constant actions drawn uniformly from [-1, 1]^n,
  each with Gaussian action noise of std ``sigma`` added every step (the same draws on either
  physics), over whole 1000-step episodes. H(s) is the MI-max rows' protocol for the HalfCheetah:
  the x velocity over the last ``last`` steps of every episode, a histogram of 1000 bins over
  [-scale, scale] (``metrics.particle.entropy``). The reading for a DIAYN_FULL row whose skills
  are poses."""
  from blx.metrics import particle
  rng = np.random.default_rng(seed)
  params = held_poses(rng, poses, num_motors)
  noise = sigma * rng.standard_normal((steps, poses, num_motors))
  velocities, _, alive = rollout(params, steps, noise)
  x = velocities[:, -last:, 0]
  h = float(particle.entropy(np.asarray(x.reshape(-1), np.float32), bins=1000,
                             value_range=(-scale, scale)))
  return dict(entropy=h, sigma=sigma, std=float(x.std()), pose_speed=x.mean(1).tolist(),
              alive=alive.tolist())


def speed_profile(velocities: np.ndarray) -> dict:
  """The mean and the within-episode std of each gait's x velocity ``[P, T, D]``."""
  vx = velocities[..., 0]
  return dict(mean_speed=vx.mean(1).tolist(), std_speed=vx.std(1).tolist())


# Brax v0.0.6's own step per body (fact sheet section 2), for labels of runs that kept it
# the paper's physics steps per control step (substeps, ms), and its control steps (s)
V006_STEP = {"ant": (10, 5.0), "halfcheetah": (16, 3.125), "pro_ant_run": (16, 1.25)}
CONTROL_STEP = {"ant": 0.05, "halfcheetah": 0.05, "pro_ant_run": 0.02}


def describe(args: dict) -> str:
  """A run's physics in words, from the arguments its JSON kept."""
  body = args["body"]
  if args["sim"] == "brax":
    sets = parse_brax_sets(args.get("brax_set") or [])
    substeps = int(sets.pop("substeps", V006_STEP[body][0]))
    dt = sets.pop("dt", CONTROL_STEP[body])
    h = 1000 * dt / substeps
    text = f"Brax v1 {' '.join([body, *(args.get('env_param') or [])])}, {substeps} x {h:.4g} ms"
    if (substeps, h) == V006_STEP[body] and not sets:
      text += " (the paper's)"
    return text + "".join(f", {k} {v:g}" for k, v in sets.items())
  edits = json.loads(args["edits"]) if args.get("edits") else {}
  body = " ".join([body, *(args.get("env_param") or [])])
  if "global_options.substeps" in edits:
    return (f"blx {body}, {edits['global_options.substeps']} x "
            f"{1000 * edits['global_options.timestep']:g} ms")
  return f"blx {body}, its default step"


def _plot_held(ax, held: list[dict]) -> None:
  """H(s) of held poses against the action noise, one line per physics, beside the paper's
  HalfCheetah DIAYN_FULL row."""
  import paper_tables
  mean, std = paper_tables.PAPER["halfcheetah"]["diayn_full"]["eval/entropy"]
  ax.axhspan(mean - std, mean + std, color="gray", alpha=0.2)
  ax.axhline(mean, color="gray", ls="--", lw=1, label="the paper's DIAYN_FULL row (mean ± std)")
  for label in sorted({describe(r["args"]) for r in held}):
    points = sorted((r["sigma"], r["entropy"]) for r in held if describe(r["args"]) == label)
    brax = label.startswith("Brax")
    ax.plot(*zip(*points), "o-", color="tab:red" if brax else "tab:blue", label=label)
  ax.set_xlabel("action noise added every step (std)")
  ax.set_ylabel("H(s) of the x velocity (nats)")
  ax.set_title("Skills that hold still: H(s) of held poses\n(1000-step episodes, the rows' "
               "protocol: last 500 steps)")
  ax.legend(fontsize=8, loc="center right")
  ax.grid(alpha=0.3)


def plot_legs(paths: list[str], png: str) -> tuple[dict, dict]:
  """How fast the procedural ant runs with each leg count, one figure: the speed searches of
  ``--body pro_ant_run`` in ``paths`` (each search seed's elite mean, blx's and Brax v1's side by
  side) and, where given, ``root_velocity.py`` JSONs of trained ``pro_ant_run`` runs (each seed's
  mean velocity's norm, the distance covered over the time as the search scores a gait), beside
  the 4 m/s that the run reward asks for. Returns the speeds drawn,
  ``{(what, legs): [m/s, ...]}`` with ``what`` one of "blx", "Brax v1", "trained" (runs of the
  row's PPO) or "trained, entropy_cost=0.1" (runs trained with other PPO settings, each apart),
  and the env steps per seed written at each trained bar's foot, ``{(what, legs): "45 M"}``
  (from the JSON's ``env_steps``; "?" for a JSON from before root_velocity.py recorded them):
  trained runs of unfinished rows stand at different budgets."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt

  groups = {}   # (what, legs) -> speeds
  trained_at = {}   # (what, legs) -> the env steps per seed of its runs
  for path in paths:
    with open(path) as f:
      r = json.load(f)
    if "seeds" in r and r.get("args", {}).get("body") == "pro_ant_run" and (
        r["args"]["score"] == "speed"):
      what = "Brax v1" if r["args"]["sim"] == "brax" else "blx"
      speeds = [seed["elite_last"] for seed in r["seeds"].values()]
      legs = common.env_params(r["args"].get("env_param") or []).get("num_legs", 4)
    elif r.get("env") == "pro_ant_run" and "per_seed" in r:
      # trained runs apart by the PPO settings they trained with over the row's, the budget aside
      # (a JSON from before root_velocity.py recorded them: the row's, as all runs were then)
      over = {k: v for k, v in (r.get("ppo") or {}).items() if k != "num_timesteps"}
      what = "trained" + "".join(f", {k}={v!r}" for k, v in sorted(over.items()))
      # the mean velocity's norm: the distance covered over the time taken
      speeds = [float(np.hypot(*seed["velocity"])) for seed in r["per_seed"].values()]
      legs = int(r.get("env_params", {}).get("num_legs", 4))
      trained_at.setdefault((what, legs), set()).add(r.get("env_steps"))
    else:
      raise ValueError(f"{path} is neither a speed search of --body pro_ant_run nor a "
                       "root_velocity.py JSON of a pro_ant_run run")
    groups.setdefault((what, legs), []).extend(speeds)
  steps = {group: "/".join("?" if n is None else f"{n / 1e6:.0f} M"
                          for n in sorted(at, key=lambda n: (n is None, n or 0)))
           for group, at in trained_at.items()}
  trained = sorted({w for w, _ in groups if w.startswith("trained")},
                   key=lambda w: (w != "trained", w))   # the row's first
  kinds = [k for k in ("blx", "Brax v1") if any(w == k for w, _ in groups)] + trained
  styles = {"blx": ("tab:blue", "open-loop gaits, blx (C MuJoCo, the env's MJCF)"),
            "Brax v1": ("tab:red", "open-loop gaits, Brax v1 (brax 0.12.1, legacy_spring)")}
  colours = iter(("tab:green", "tab:purple", "tab:brown", "tab:olive"))
  for kind in trained:   # the row's PPO in black, each other setting a colour of its own
    settings = kind[len("trained, "):] or "the row's PPO"
    styles[kind] = ("k" if kind == "trained" else next(colours, "tab:gray"),
                    f"trained policies, {settings} (root_velocity.py, sampled actions)")
  legs = sorted({n for _, n in groups})
  width = 0.8 / len(kinds)
  fig, ax = plt.subplots(figsize=(7.5, 6))
  for k, kind in enumerate(kinds):
    color, label = styles[kind]
    for x, n in enumerate(legs):
      speeds = groups.get((kind, n))
      if not speeds:
        continue
      pos = x - 0.4 + width * (k + 0.5)
      ax.bar(pos, np.mean(speeds), width * 0.9, color=color, alpha=0.3, label=label)
      label = None   # one legend entry per kind
      ax.plot(np.full(len(speeds), pos), speeds, "o", color=color, ms=4)
      # a gait scores 0 where the ant falls
      if not kind.startswith("trained") and max(speeds) == 0:
        ax.text(pos, 0.08, "all\nfall", ha="center", fontsize=8, color=color)
      if (kind, n) in steps:
        ax.text(pos, 0.05, steps[kind, n], ha="center", va="bottom", fontsize=7, rotation=90)
  ax.axhline(4.0, color="gray", ls="--", lw=1, label="the run reward's target speed (4 m/s)")
  ax.set_xticks(range(len(legs)), [f"{n} legs" for n in legs])
  ax.set_ylabel("the torso's planar speed (distance covered / time), m/s")
  ax.set_ylim(0, 4.6)
  ax.set_title("pro_ant_run: how fast each leg count runs\n(bars: mean; dots: each search seed's "
               "12 best gaits, or each trained seed;\nat a trained bar's foot: its env steps per "
               "seed)")
  ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1))  # under the bars
  ax.grid(alpha=0.3, axis="y")
  fig.tight_layout()
  fig.savefig(png, dpi=120)
  plt.close(fig)
  return groups, steps


def plot_study(paths: list[str], png: str, reference: str | None = None) -> None:
  """One figure of the JSONs ``paths`` this script wrote: the swing searches' elite RMS per target
  speed (left), the constant-action drifts (middle) and, if given, the held poses' H(s) (right).
  ``reference``: a ``goal_reaching.py`` JSON whose mean within-episode spread is drawn as the
  trained policy's."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt

  runs = []
  for path in paths:
    with open(path) as f:
      runs.append(json.load(f))
  swings = [r for r in runs if r["args"]["score"] == "swing" and "seeds" in r]
  drifts = [r for r in runs if "drift" in r]
  held = [r for r in runs if "entropy" in r]
  if not swings and not drifts:
    raise ValueError(f"none of {paths} is a swing search or a drift run of gait_search.py")
  ratios = [1, 1.2] + ([0.8] if held else [])
  fig, axes = plt.subplots(1, len(ratios), figsize=(7 * sum(ratios) / 1.1, 5.5),
                           gridspec_kw=dict(width_ratios=ratios))
  left, right = axes[0], axes[1]
  if held:
    _plot_held(axes[2], held)
  labels = sorted({describe(r["args"]) for r in swings})
  targets = sorted({r["args"]["target"] for r in swings})
  palettes = dict(brax=iter(["tab:red", "tab:orange", "tab:pink", "tab:brown"]),
                  blx=iter(["tab:blue", "tab:cyan", "tab:green", "tab:purple"]))
  sims = {describe(r["args"]): r["args"]["sim"] for r in swings}
  colors = {label: next(palettes[sims[label]]) for label in labels}   # red: Brax, blue: blx
  width = 0.8 / max(len(labels), 1)
  for r in swings:
    label = describe(r["args"])
    k, x = labels.index(label), targets.index(r["args"]["target"])
    rms = [-seed["elite_last"] for seed in r["seeds"].values()]
    pos = x - 0.4 + width * (k + 0.5)
    left.bar(pos, np.mean(rms), width * 0.9, color=colors[label], alpha=0.35)
    left.plot(np.full(len(rms), pos), rms, "o", color=colors[label], ms=4)
  for label in labels:
    left.bar(np.nan, np.nan, color=colors[label], alpha=0.6, label=label)
  if reference:
    with open(reference) as f:
      spread = json.load(f)["summary"]["spread_within"][0]
    left.axhline(spread, color="k", ls="--", lw=1,
                 label=f"blx's trained GCRL policy: speed std within an episode ({spread:.2f})")
  left.set_ylim(0, 1.4 * max(-seed["elite_last"] for r in swings for seed in r["seeds"].values()))
  left.set_xticks(range(len(targets)), [f"{t:+g} m/s" for t in targets])
  left.set_xlabel("the speed to hold (target)")
  left.set_ylabel("RMS of (torso x speed - target), m/s\n(the 12 best gaits of the last round)")
  left.set_title("How steadily open-loop gaits hold a speed\n(bars: mean over search seeds; dots: "
                 "each seed)")
  left.legend(fontsize=8, loc="upper left")
  left.grid(alpha=0.3, axis="y")
  def order(r):   # per body: blx, then Brax at its own step, finer steps, then other settings
    sets = parse_brax_sets(r["args"].get("brax_set") or [])
    return (r["args"]["body"], r["args"]["sim"] == "brax", len(sets) - ("substeps" in sets),
            sets.get("substeps", 0), describe(r["args"]))
  drifts.sort(key=order)
  for i, r in enumerate(drifts):
    d = np.maximum(np.asarray(r["drift"]), 1e-4)
    jitter = np.random.default_rng(i).uniform(-0.2, 0.2, len(d))
    right.plot(i + jitter, d, ".", color="tab:red" if r["args"]["sim"] == "brax" else "tab:blue",
               alpha=0.5, ms=4)
    right.plot([i - 0.3, i + 0.3], [np.median(d)] * 2, "k-", lw=2)
    right.text(i, 6.0, f"{100 * r['share_above_0_1']:.0f}%", ha="center", fontsize=8)
  right.axhline(0.1, color="gray", ls=":", lw=1)
  for color, name in (("tab:blue", "blx (MuJoCo)"),
                      ("tab:red", "Brax v1 (brax 0.12.1, legacy_spring)")):
    right.plot([], [], "o", color=color, label=name)
  right.legend(fontsize=8, loc="lower right")
  right.set_yscale("log")
  right.set_ylim(1e-4, 12)
  right.set_xticks(range(len(drifts)), [describe(r["args"]).replace(", ", "\n", 1)
                                        for r in drifts], fontsize=7, rotation=30, ha="right")
  right.set_ylabel("|mean torso x speed| over the last 2.5 s, m/s (log)")
  right.set_title("Held poses: does the body come to rest?\n(each dot a random constant action; "
                  "bar: median; top: share above 0.1 m/s)")
  right.grid(alpha=0.3, axis="y")
  fig.tight_layout()
  fig.savefig(png, dpi=120)
  plt.close(fig)


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--sim", choices=["blx", "brax"], default=None,
                      help="the physics to search on (required unless --plot)")
  parser.add_argument("--body", choices=BODIES, default="ant")
  parser.add_argument("--edits", default=None, metavar="JSON", help="blx: edits of the body's desc")
  parser.add_argument("--env-param", action="append", default=[], metavar="KEY=VALUE",
                      help="blx: a parameter of the body's env (repeatable), e.g. num_legs=3 for "
                           "pro_ant_run; brax: num_legs of pro_ant_run alone")
  parser.add_argument("--no-cut", action="store_true", help="blx: no torque cut (diagnostic only)")
  parser.add_argument("--brax-config", default=None, help="brax: a Brax v1 config in text format")
  parser.add_argument("--brax-set", action="append", default=[], metavar="FIELD=VALUE",
                      help="brax: replace a top-level config field first (repeatable): "
                           + ", ".join(BRAX_SETTABLE) + " (friction per collider, before the "
                           "square root)")
  parser.add_argument("--score", choices=SCORES, default="speed",
                      help="speed: planar speed (m/s); energy (ant): minus the energy distance of "
                           "the torso's xy velocities to GAIL's bimodal target; swing: minus the "
                           "RMS of (x velocity - --target) (m/s)")
  parser.add_argument("--target", type=float, default=None, help="swing: the speed to hold (m/s)")
  parser.add_argument("--drift", type=int, default=None, metavar="POSES",
                      help="no search: roll out POSES random constant actions and report how fast "
                           "the torso still moves over the last 2.5 s")
  parser.add_argument("--held", type=int, default=None, metavar="POSES",
                      help="no search (halfcheetah): H(s) of POSES held poses over 1000-step "
                           "episodes, with --noise")
  parser.add_argument("--noise", type=float, default=None, metavar="SIGMA",
                      help="--held: the std of the Gaussian action noise added every step")
  parser.add_argument("--plot", nargs="+", default=None, metavar=("PNG", "JSON"),
                      help="no run: draw the swing searches and drifts in the JSONs into PNG")
  parser.add_argument("--plot-legs", nargs="+", default=None, metavar=("PNG", "JSON"),
                      help="no run: draw the speed searches of --body pro_ant_run in the JSONs, "
                           "and root_velocity.py JSONs of trained pro_ant_run runs, by leg count")
  parser.add_argument("--reference", default=None,
                      help="--plot: a goal_reaching.py JSON whose within-episode spread to draw")
  parser.add_argument("--seeds", type=int, default=4)
  parser.add_argument("--iters", type=int, default=60)
  parser.add_argument("--out", default=None, help="write per-seed results as JSON here")
  args = parser.parse_args()
  if args.plot is not None:
    if len(args.plot) < 2 or not args.plot[0].endswith(".png"):
      parser.error("--plot takes the PNG to write, then one or more JSONs of this script")
    try:
      plot_study(args.plot[1:], args.plot[0], args.reference)
    except (OSError, KeyError, ValueError) as err:
      parser.error(f"--plot: {err}")
    print(f"wrote {args.plot[0]}")
    return
  if args.plot_legs is not None:
    if len(args.plot_legs) < 2 or not args.plot_legs[0].endswith(".png"):
      parser.error("--plot-legs takes the PNG to write, then one or more JSONs")
    try:
      plot_legs(args.plot_legs[1:], args.plot_legs[0])
    except (OSError, KeyError, ValueError) as err:
      parser.error(f"--plot-legs: {err}")
    print(f"wrote {args.plot_legs[0]}")
    return
  if args.sim is None:
    parser.error("--sim is required (blx or brax) unless --plot or --plot-legs")
  if args.sim == "brax" and args.body == "pro_ant_run" and args.brax_config:
    parser.error("--sim brax --body pro_ant_run builds the paper's procedural ant itself "
                 "(--env-param num_legs=N): give no --brax-config")
  if args.sim == "brax" and args.body != "pro_ant_run" and not args.brax_config:
    parser.error(f"--sim brax --body {args.body} needs --brax-config")
  if args.sim == "blx" and args.brax_config:
    parser.error("--brax-config is for --sim brax; --sim blx builds the body from blx's registry")
  if (args.score == "swing") != (args.target is not None):
    parser.error("--target is required by --score swing and taken by no other score")
  if args.score == "energy" and args.body != "ant":
    parser.error("--score energy compares xy velocities with GAIL's 2-D target: --body ant only")
  if args.seeds < 1 or args.iters < 1:
    parser.error("--seeds and --iters must be at least 1")
  if args.drift is not None and (args.drift < 1 or args.score != "speed"):
    parser.error("--drift takes a number of poses (at least 1) and no --score: it searches nothing")
  if args.sim == "brax" and (args.edits or args.no_cut):
    parser.error("--edits and --no-cut change blx's body: --sim blx only (Brax takes --brax-set)")
  if args.held is not None and (args.held < 1 or args.body != "halfcheetah"
                                or args.drift is not None or args.score != "speed"):
    parser.error("--held takes a number of poses (at least 1), --body halfcheetah (whose episodes "
                 "never end) and neither --drift nor --score")
  if (args.noise is not None) != (args.held is not None) or (args.noise or 0) < 0:
    parser.error("--noise (a std >= 0) goes with --held, and --held needs it")
  if args.brax_set and args.sim != "brax":
    parser.error("--brax-set edits a Brax config: --sim brax only (blx takes --edits)")
  if args.sim == "brax" and args.env_param and args.body != "pro_ant_run":
    parser.error("--env-param sets a parameter of blx's env, or the legs of --sim brax --body "
                 "pro_ant_run")
  if args.drift is not None and args.body == "pro_ant_run":
    parser.error("--drift reads the last 2.5 s at a control step of 0.05 s: --body ant or "
                 "halfcheetah")
  try:
    env_params = common.env_params(args.env_param)
  except ValueError as err:
    parser.error(str(err))
  try:
    sets = parse_brax_sets(args.brax_set)
  except ValueError as err:
    parser.error(str(err))
  if args.sim == "brax" and args.body == "pro_ant_run":
    if set(env_params) - {"num_legs"}:
      parser.error(f"--sim brax --body pro_ant_run takes --env-param num_legs=N alone, got "
                   f"{sorted(env_params)}")
    try:
      text = brax_pro_ant_config(env_params.get("num_legs", 4))
    except ValueError as err:
      parser.error(f"--env-param {err}")
    rollout, motors = brax_rollout(None, args.body, sets, text=text)
  elif args.sim == "brax":
    rollout, motors = brax_rollout(args.brax_config, args.body, sets)
  else:
    try:
      rollout, motors = blx_rollout(args.body, json.loads(args.edits) if args.edits else None,
                                    cut=not args.no_cut, env_params=env_params)
    except (TypeError, ValueError) as err:
      parser.error(f"--body {args.body} with --env-param {args.env_param}: {err}")
  if args.held is not None:
    found = held_pose_entropy(rollout, motors, args.held, args.noise)
    print(f"{args.held} held poses, action noise {args.noise:g}: H(s) {found['entropy']:.3f}, "
          f"x velocity std {found['std']:.3f} m/s over the last 500 steps of 1000")
    if args.out:
      with open(args.out, "w") as f:
        json.dump(dict(args=vars(args), **found), f, indent=1)
    return
  if args.drift is not None:
    found = constant_action_drift(rollout, motors, args.drift)
    print(f"{args.drift} constant actions: the torso's |mean x velocity| over the last 2.5 s is "
          f"{found['median']:.3f} m/s (median), at most {found['max']:.3f} m/s; "
          f"{100 * found['share_above_0_1']:.0f}% of the poses still move faster than 0.1 m/s")
    if args.out:
      with open(args.out, "w") as f:
        json.dump(dict(args=vars(args), **found), f, indent=1)
    return
  score = scores_of(args.score, rollout, args.target)
  unit = {"speed": "m/s", "energy": "(-energy distance)", "swing": "(-RMS m/s)"}[args.score]
  results = {}
  for seed in range(args.seeds):
    start = time.time()
    found = cross_entropy(score, motors, seed, args.iters)
    results[seed] = dict(best=found["best"], elite_last=found["elite_means"][-1],
                         elite_means=found["elite_means"], params=found["best_params"].tolist())
    line = (f"seed {seed}: best {found['best']:.3f} {unit}, elite mean "
            f"{found['elite_means'][-1]:.3f} {unit}")
    if args.score == "swing":
      profile = speed_profile(rollout(found["elite_params"])[0])
      results[seed]["elite_profile"] = profile
      line += (f"; the elite's speed {np.mean(profile['mean_speed']):.2f} m/s, its std within "
               f"the episode {np.mean(profile['std_speed']):.3f} m/s")
    print(f"{line} ({time.time() - start:.0f} s)", flush=True)
  if args.out:
    with open(args.out, "w") as f:
      json.dump(dict(args=vars(args), seeds=results), f, indent=1)


if __name__ == "__main__":
  main()
