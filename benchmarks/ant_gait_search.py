"""How fast can the ant run? A cross-entropy search over open-loop sinusoid gaits, on blx's ant (C
MuJoCo, float64, the env's own MJCF and torque cut) or on Brax v1's physics, with one budget.

    python benchmarks/ant_gait_search.py --sim blx [--edits JSON] [--no-cut] [--seeds 4]
    python benchmarks/ant_gait_search.py --sim brax --brax-config ant_v006.txt   # needs brax 0.12.1

A gait is a_j(t) = clip(amp_j sin(2 pi f t + phase_j) + bias_j, -1, 1) for the 8 motors (25
numbers). Its score is the torso's planar speed over 5 s after a 1 s warm-up, 0 if the torso leaves
z in [0.2, 1]. Each seed runs ``--iters`` rounds of 96 samples, refitting a diagonal Gaussian to the
best 12. Printed per seed: the best score (optimistic: gaits are chaotic, so the best of 96 is partly
luck) and the elite mean of the last round (the figure to compare).

``--score energy`` asks instead whether a gait can spread the torso's xy velocity over GAIL's
bimodal target (modes (+-4, 0) m/s, std 0.8; the paper's D-min rows): the score is minus the energy
distance between the torso's xy velocity at every step after the warm-up and the target's 250
samples (higher is better; velocities spread like one of the two modes, N((4, 0), 0.8^2 I),
score about -2.8, standing still -3.4).

``--sim brax`` builds a Brax v1 system from a Brax config in text format (e.g. ``_SYSTEM_CONFIG`` of
``brax/envs/ant.py`` at v0.0.6) with ``dynamics_mode: "legacy_spring"``: Brax 0.12.1's ``brax.v1``,
with the two jax aliases the fact sheet lists (``shared/reference/brax-v1-bodies.md`` section 10).
"""

from __future__ import annotations

import argparse
import functools
import json
import time

import numpy as np

STEPS, WARM, DT = 120, 20, 0.05
POPULATION, ELITE = 96, 12


def gait_actions(params: np.ndarray, t: int) -> np.ndarray:
  """Actions ``[P, 8]`` of gaits ``params [P, 25]`` at env step ``t``."""
  amp, phase = np.clip(params[:, :8], 0, 1.5), params[:, 8:16]
  bias, freq = np.clip(params[:, 16:24], -1, 1), np.clip(params[:, 24:25], 0.5, 4.0)
  return np.clip(amp * np.sin(2 * np.pi * freq * t * DT + phase) + bias, -1, 1)


def cross_entropy(score, seed: int, iters: int):
  """Maximises ``score(params [P, 25]) -> [P]``: (best score, its params, elite mean per round)."""
  rng = np.random.default_rng(seed)
  mean = np.concatenate([np.full(8, 0.8), np.zeros(16), [2.0]])
  std = np.concatenate([np.full(8, 0.4), np.full(8, np.pi), np.full(8, 0.3), [1.0]])
  best, best_params, elite_means = -np.inf, None, []
  for _ in range(iters):
    params = mean + std * rng.standard_normal((POPULATION, 25))
    scores = score(params)
    elite = np.argsort(-scores)[:ELITE]
    if scores[elite[0]] > best:
      best, best_params = float(scores[elite[0]]), params[elite[0]].copy()
    mean, std = params[elite].mean(0), params[elite].std(0) + 0.02
    elite_means.append(float(scores[elite].mean()))
  return best, best_params, elite_means


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


def blx_score(edits: dict | None, cut: bool, energy: bool = False):
  import mujoco

  from blx import envs
  env = envs.unwrap(envs.create("ant", edits=edits))
  m, torque_cut = env.mj_model, env.torque_cut

  def ctrl(action, qpos):
    action = action.astype(np.float64)
    if cut and len(torque_cut.actuators):
      angle = qpos[torque_cut.qpos_adr]
      action[torque_cut.actuators] *= (angle >= torque_cut.low) & (angle <= torque_cut.high)
    return action

  def score(params):
    out = np.zeros(len(params))
    velocities = np.zeros((len(params), STEPS - WARM, 2))
    alive = np.zeros(len(params), bool)
    for i in range(len(params)):
      d = mujoco.MjData(m)
      d.qpos[:] = env.init_qpos
      mujoco.mj_forward(m, d)
      for t in range(STEPS):
        if t == WARM:
          start = d.qpos[:2].copy()
        action = gait_actions(params[i:i + 1], t)[0]
        for _ in range(env.substeps):
          d.ctrl[:] = ctrl(action, d.qpos)
          mujoco.mj_step(m, d)
        if not (0.2 <= d.qpos[2] <= 1.0 and np.isfinite(d.qpos).all()):
          break
        if t >= WARM:
          velocities[i, t - WARM] = d.qvel[:2]
      else:
        alive[i] = True
        out[i] = np.linalg.norm(d.qpos[:2] - start) / ((STEPS - WARM) * DT)
    return energy_score(velocities, alive) if energy else out

  return score


def brax_score(config_path: str, energy: bool = False):
  import jax
  import jax.numpy as jnp
  from jax._src import core as jax_core
  from jax._src.interpreters import batching
  jax.interpreters.batching.BatchTracer = batching.BatchTracer
  if not hasattr(jax.core, "unsafe_am_i_under_a_jit_DO_NOT_USE"):
    jax.core.unsafe_am_i_under_a_jit_DO_NOT_USE = jax_core.unsafe_am_i_under_a_jit
  from brax import v1 as brax
  from google.protobuf import text_format

  with open(config_path) as f:
    text = f.read() + '\ndynamics_mode: "legacy_spring"\n'
  system = brax.System(text_format.Parse(text, brax.Config()))
  qp0 = system.default_qp()

  def one(params):
    amp, phase = jnp.clip(params[:8], 0, 1.5), params[8:16]
    bias, freq = jnp.clip(params[16:24], -1, 1), jnp.clip(params[24], 0.5, 4.0)

    def step(carry, t):
      qp, alive, start = carry
      action = jnp.clip(amp * jnp.sin(2 * jnp.pi * freq * t * DT + phase) + bias, -1, 1)
      qp, _ = system.step(qp, action)
      alive &= (qp.pos[0, 2] >= 0.2) & (qp.pos[0, 2] <= 1.0)
      start = jnp.where(t == WARM - 1, qp.pos[0, :2], start)
      return (qp, alive, start), qp.vel[0, :2]

    (qp, alive, start), vel = jax.lax.scan(step, (qp0, jnp.array(True), qp0.pos[0, :2]),
                                           jnp.arange(STEPS))
    speed = jnp.where(alive, jnp.linalg.norm(qp.pos[0, :2] - start) / ((STEPS - WARM) * DT), 0.0)
    return speed, alive, vel[WARM:]

  batched = jax.jit(jax.vmap(one))

  def score(params):
    speed, alive, vel = batched(jnp.asarray(params, jnp.float32))
    if energy:
      return energy_score(np.asarray(vel, np.float64), np.asarray(alive))
    return np.asarray(speed)

  return score


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("--sim", choices=["blx", "brax"], required=True)
  parser.add_argument("--edits", default=None, metavar="JSON", help="edits of the ant's desc")
  parser.add_argument("--no-cut", action="store_true", help="blx: no torque cut (diagnostic only)")
  parser.add_argument("--brax-config", default=None, help="brax: a Brax v1 config in text format")
  parser.add_argument("--score", choices=["speed", "energy"], default="speed",
                      help="speed: planar speed (m/s); energy: minus the energy distance of the "
                           "torso's xy velocities to GAIL's bimodal target")
  parser.add_argument("--seeds", type=int, default=4)
  parser.add_argument("--iters", type=int, default=60)
  parser.add_argument("--out", default=None, help="write per-seed results as JSON here")
  args = parser.parse_args()
  if args.sim == "brax":
    if not args.brax_config:
      parser.error("--sim brax needs --brax-config")
    score = brax_score(args.brax_config, energy=args.score == "energy")
  else:
    score = blx_score(json.loads(args.edits) if args.edits else None, cut=not args.no_cut,
                      energy=args.score == "energy")
  results = {}
  for seed in range(args.seeds):
    start = time.time()
    best, params, elite = cross_entropy(score, seed, args.iters)
    results[seed] = dict(best=best, elite_last=elite[-1], params=params.tolist())
    unit = "m/s" if args.score == "speed" else "(-energy distance)"
    print(f"seed {seed}: best {best:.2f} {unit}, elite mean {elite[-1]:.2f} {unit} "
          f"({time.time() - start:.0f} s)", flush=True)
  if args.out:
    with open(args.out, "w") as f:
      json.dump(results, f, indent=1)


if __name__ == "__main__":
  main()
