"""Whether a cheaper half-cheetah step keeps the body's behaviour (#15): candidates for
``global_options`` against blx's step (16 substeps of 3.125 ms, 4 Newton iterations) and against a
converged float64 solve.

    python benchmarks/cheetah_step.py [--episodes 8] [--steps 1000] [--horizon 40]
                                      [--candidates JSON] [--speed --num-envs 20480] [--out FILE]

Each candidate is a set of ``global_options`` edits over the half-cheetah's (``CHEETAH_OPTIONS``);
every candidate keeps the env step at 50 ms (``timestep`` x ``substeps``), so actions, rewards and
the paper's protocol are unchanged. All candidates see the same uniform random actions from the
same start. Per candidate:

- ``diverge_s``: how long its MJX trajectory stays within 5 cm (torso x) and 0.1 rad (pitch) of the
  *truth*: C MuJoCo in float64 at blx's 3.125 ms with the Newton solve run to convergence (100
  iterations, 50 line-search steps, tolerance 1e-10), under the same actions. The half-cheetah is
  chaotic under random actions, so no step follows the truth for ever: ``chaos_s`` is how long the
  truth stays within the same band of itself started 1e-6 rad away (the horizon no integrator can
  beat); blx's own step's figure is the reference. It ranks per-step error, not behaviour.
  Median over episodes.
- over ``--steps`` env steps of each episode (MJX, the step as trained): the torso's mean and std
  x velocity, its mean height, the mean |pitch rate| and the share of steps flipped (|pitch| > 90
  deg from the reset pose: turned over, or turned round once or more). Signatures a policy's
  behaviour lives on; compare them with blx's step's, which the tests hold to Brax v1's
  (``tests/envs/test_brax_bodies.py``).
- ``gait_vx/F``: the torso's mean x velocity over the last half of an episode driven open-loop by
  a bounding gait at F Hz (every motor a sine, the back leg half a period behind the front; the
  same actions for every candidate): how fast one fixed gait carries the body, the quantity the
  paper's x-velocity skills and targets are measured on. ``gait_flipped/F``: its share of flipped
  steps. (On the H200, these gaits turned the body over in 62-98% of their steps under every
  step tried, so their speeds carried no signal; read them beside ``gait_flipped``.)
- with ``--speed`` (meant for the GPU): env steps/s of the jitted, vmapped env step at
  ``--num-envs``, and its ratio to blx's step measured in the same call.

Prints a Markdown table and one JSON line per candidate; ``--out`` writes them all as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import common  # noqa: E402

from blx import envs  # noqa: E402
from blx.envs.brax_bodies import CHEETAH_OPTIONS  # noqa: E402
from tests.envs import mujoco_reference as reference  # noqa: E402

BLX = "blx: 16 x 3.125 ms, 4 it"
CANDIDATES = {
    BLX: {},
    "16 x 3.125 ms, 2 it": {"iterations": 2},
    "16 x 3.125 ms, 1 it": {"iterations": 1},
    "10 x 5 ms, 4 it": {"timestep": 0.005, "substeps": 10},
    "10 x 5 ms, 2 it": {"timestep": 0.005, "substeps": 10, "iterations": 2},
    "8 x 6.25 ms, 4 it": {"timestep": 0.00625, "substeps": 8},
}
GAIT_HZ = (1.0, 2.0, 3.0)
X_BAND, PITCH_BAND = 0.05, 0.1   # m, rad
ROOTX, ROOTY = 0, 2              # qpos: rootx, rootz, rooty, six hinges


def make(edits: dict):
  """The half-cheetah with ``edits`` over its ``global_options``; refuses a changed env step."""
  valid = sorted(set(CHEETAH_OPTIONS) | {"ls_iterations", "solver"})
  if set(edits) - set(valid):
    raise ValueError(f"--candidates: unknown global_options {sorted(set(edits) - set(valid))}; "
                     f"a candidate sets some of {valid}")
  merged = {**CHEETAH_OPTIONS, **edits}
  if abs(merged["timestep"] * merged["substeps"] - 0.05) > 1e-9:
    raise ValueError(f"--candidates: timestep x substeps must stay 0.05 s (Brax v1's env step); "
                     f"{edits} gives {merged['timestep'] * merged['substeps']:g}")
  return envs.unwrap(envs.create("halfcheetah", edits={f"global_options.{k}": v
                                                       for k, v in edits.items()}))


def mjx_rollout(env, actions: np.ndarray, qpos0: np.ndarray) -> np.ndarray:
  """qpos after each env step [B, T, nq] of MJX from ``qpos0`` [B, nq] under ``actions`` [B, T, A]."""

  @jax.jit
  def run(qpos0, actions):
    def one(qpos, acts):
      state = env.reset(jax.random.PRNGKey(0))
      state = state.replace(data=state.data.replace(qpos=qpos))

      def body(s, a):
        s = env.step(s, a)
        return s, s.data.qpos
      return jax.lax.scan(body, state, acts)[1]
    return jax.vmap(one)(qpos0, actions)

  return np.asarray(run(jnp.asarray(qpos0, jnp.float32), jnp.asarray(actions, jnp.float32)))


def truth_rollout(env, actions: np.ndarray, qpos0: np.ndarray) -> np.ndarray:
  """qpos [T, nq] of one episode in C MuJoCo, float64, blx's 3.125 ms, the solve converged."""
  model = env.mj_model.__copy__()
  model.opt.iterations, model.opt.ls_iterations, model.opt.tolerance = 100, 50, 1e-10
  return reference.run(env, lambda t, q: actions[t], len(actions), model=model,
                       qpos0=qpos0)["qpos"]


def horizon(a: np.ndarray, b: np.ndarray, dt: float) -> float:
  """Seconds until trajectories ``a``, ``b`` [T, nq] leave the x / pitch band (T*dt if never)."""
  out = (np.abs(a[:, ROOTX] - b[:, ROOTX]) > X_BAND) | (np.abs(a[:, ROOTY] - b[:, ROOTY])
                                                         > PITCH_BAND)
  return (int(np.argmax(out)) if out.any() else len(a)) * dt


def signatures(qpos: np.ndarray, dt: float) -> dict:
  """Behaviour over episodes ``qpos`` [B, T, nq]."""
  vx = np.diff(qpos[:, :, ROOTX], axis=1) / dt
  pitch = qpos[:, :, ROOTY]
  rate = np.abs(np.diff(pitch, axis=1)) / dt
  return dict(vx_mean=float(vx.mean()), vx_std=float(vx.std()),
              z_mean=float(0.6 + qpos[:, :, 1].mean()), pitch_rate=float(rate.mean()),
              flipped=float((np.abs(pitch) > np.pi / 2).mean()),
              finite=bool(np.isfinite(qpos).all()))


def gait_actions(hz: float, steps: int, dt: float) -> np.ndarray:
  """[T, 6] a bounding gait: back leg (bthigh, bshin, bfoot) half a period behind the front leg."""
  t = np.arange(steps)[:, None] * dt
  phase = np.array([np.pi, np.pi + 0.5, np.pi + 1.0, 0.0, 0.5, 1.0])
  return np.sin(2 * np.pi * hz * t + phase)


def speed(env, num_envs: int, steps: int = 50) -> float:
  """Env steps/s of the jitted, vmapped env step (best of 3 after compiling)."""
  run, args = common.env_step_runner(env, num_envs, steps)
  _, calls = common.time_calls(run, lambda i: args, repeats=3)
  return num_envs * steps / min(calls)


def main() -> None:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  parser.add_argument("--episodes", type=int, default=8)
  parser.add_argument("--steps", type=int, default=1000, help="env steps per episode (signatures)")
  parser.add_argument("--horizon", type=int, default=40, help="env steps compared with the truth")
  parser.add_argument("--candidates", default=None, metavar="JSON",
                      help='{"name": {global_options edits}}; default: the built-in set')
  parser.add_argument("--speed", action="store_true", help="also time the env step (on a GPU)")
  parser.add_argument("--num-envs", type=int, default=20480)
  parser.add_argument("--out", default=None)
  args = parser.parse_args()
  for flag in ("episodes", "steps", "horizon", "num_envs"):
    if getattr(args, flag) < 1:
      raise SystemExit(f"--{flag.replace('_', '-')} must be at least 1")
  if args.horizon > args.steps:
    raise SystemExit(f"--horizon ({args.horizon}) must not exceed --steps ({args.steps})")
  try:
    candidates = json.loads(args.candidates) if args.candidates else CANDIDATES
  except json.JSONDecodeError as e:
    raise SystemExit(f"--candidates: not JSON ({e}); give {{\"name\": {{\"iterations\": 2}}}}")
  if not isinstance(candidates, dict) or not all(isinstance(v, dict) for v in candidates.values()):
    raise SystemExit(f"--candidates: give a JSON object of name -> global_options edits, e.g. "
                     f"{{\"8 x 6.25 ms\": {{\"timestep\": 0.00625, \"substeps\": 8}}}}; got "
                     f"{args.candidates}")
  candidates = {BLX: {}, **candidates}

  base = make({})
  dt = 0.05
  rng = np.random.default_rng(0)
  actions = rng.uniform(-1, 1, (args.episodes, args.steps, base.action_size))
  qpos0 = np.repeat(np.asarray(base.init_qpos)[None], args.episodes + len(GAIT_HZ), 0)
  h = args.horizon
  gait = np.stack([gait_actions(hz, args.steps, dt) for hz in GAIT_HZ])
  truth = [truth_rollout(base, actions[i, :h], qpos0[i]) for i in range(args.episodes)]
  nudged = qpos0.copy()
  nudged[:, 3] += 1e-6
  chaos = [horizon(truth[i], truth_rollout(base, actions[i, :h], nudged[i]), dt)
           for i in range(args.episodes)]
  print(f"chaos horizon (truth against itself 1e-6 rad away): median {np.median(chaos):.2f} s, "
        f"per episode {[round(c, 2) for c in chaos]}", flush=True)

  rows, base_speed = [], None
  for name, edits in candidates.items():
    env = make(edits)
    t = time.perf_counter()
    # One rollout (one compile) for the random episodes and the gaits, all from the reset pose.
    both = mjx_rollout(env, np.concatenate([actions, gait]), qpos0)
    qpos, gaits = both[:args.episodes], both[args.episodes:]
    extra = {}
    for hz, q in zip(GAIT_HZ, gaits):
      half = q[args.steps // 2:]
      extra[f"gait_vx/{hz:g}"] = float((half[-1, ROOTX] - half[0, ROOTX]) / ((len(half) - 1) * dt))
      extra[f"gait_flipped/{hz:g}"] = float((np.abs(q[:, ROOTY]) > np.pi / 2).mean())
    row = dict(candidate=name, edits=edits, seconds=time.perf_counter() - t,
               diverge_s=float(np.median([horizon(qpos[i, :h], truth[i], dt)
                                          for i in range(args.episodes)])),
               chaos_s=float(np.median(chaos)), **signatures(qpos, dt), **extra)
    if args.speed:
      row["env_steps_per_s"] = speed(env, args.num_envs)
      base_speed = base_speed or row["env_steps_per_s"]
      row["speed_ratio"] = row["env_steps_per_s"] / base_speed
    rows.append(row)
    print(json.dumps(row), flush=True)

  columns = [("candidate", "candidate", ""), ("stays with the truth, s", "diverge_s", ".2f"),
             ("vx mean", "vx_mean", "+.3f"), ("vx std", "vx_std", ".3f"),
             ("torso z", "z_mean", ".3f"), ("abs pitch rate", "pitch_rate", ".2f"),
             ("flipped share", "flipped", ".3f")]
  columns += [(f"gait {hz:g} Hz vx", f"gait_vx/{hz:g}", "+.2f") for hz in GAIT_HZ]
  if args.speed:
    columns += [("env steps/s", "env_steps_per_s", ",.0f"), ("x blx", "speed_ratio", ".2f")]
  common.print_table(f"; {args.episodes} random-action episodes of {args.steps} steps; truth "
                     f"compared over {args.horizon}; chaos horizon {np.median(chaos):.2f} s",
                     rows, columns)
  if args.out:
    with open(args.out, "w") as f:
      json.dump(dict(chaos_s=chaos, rows=rows), f, indent=1)


if __name__ == "__main__":
  main()
