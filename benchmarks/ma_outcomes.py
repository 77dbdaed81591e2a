"""What the agents of a trained multi-agent run do to each other: each agent's trained policy against
a uniformly random opponent, and both trained, from one run directory.

    python benchmarks/ma_outcomes.py RUN_DIR [--episodes 32] [--steps 1000] [--seed-index 0]
        [--catch-distance 0.5] [--escape-distance 20] [--ring 3.0] [--json OUT.json]

Arms (agent0, agent1): trained / trained, trained / random, random / trained, random / random. A
random agent acts uniformly in [-1, 1]; a trained one takes its policy's deterministic action. Every
arm runs ``--episodes`` episodes from the env's own reset (the same reset keys in every arm) until
the env ends the episode or ``--steps`` pass. Per arm, over the episodes:

* ``ended early``: the share of episodes the env ended before ``--steps`` (a catch in ``chase``;
  a fall or a ring-out in ``sumo``; any agent's termination);
* ``caught``: the share that ended with the two torsos closer than ``--catch-distance`` (``chase``'s
  rule, 0.5 m in the original) and the mean steps to that end;
* ``escaped``: the share that ended with them farther apart than ``--escape-distance`` (``chase``:
  20 m); an early end that is neither is a fall (a torso out of its height range) or a ring-out;
* ``final distance``: between the two torsos (xy) at the episode's last step;
* ``outside ring``: per agent, the share of episodes whose last step has its torso farther than
  ``--ring`` from the origin in xy (``sumo``'s ring, 3 m by default).

Compare an arm with the random-opponent arms: a pursuer that learned catches a random prey more
often than a random pursuer does, and a prey that learned survives a trained pursuer longer.
"""

from __future__ import annotations

import argparse
import json

import jax
import jax.numpy as jnp
import numpy as np

from blx import envs
from blx.experiments import runs


def make_rollouts(run: runs.Run, seed_index: int, episodes: int, steps: int):
  """``rollouts(trained, key) -> (xy, alive)``: ``episodes`` episodes with agent i trained where
  ``trained[i]``, else uniformly random; root-body (torso) xy per agent after each step
  ``[E, T, A, 2]``, and ``alive [E, T]`` (True while no end happened before step t, so the step an
  episode ends on still counts). One compiled program serves every arm."""
  env, base = run.env, envs.unwrap(run.env)
  roots = base.tracked_bodies  # each actuated component's root body, in the agents' order
  if len(roots) != len(base.agent_names):
    raise ValueError(f"{run.directory}: {len(roots)} actuated components for agents "
                     f"{list(base.agent_names)}; this compares scenes of one body per agent")
  roots = jnp.asarray(roots)
  params = jax.tree.map(lambda x: x[seed_index], run.params)

  @jax.jit
  def go(mask, key):  # mask [A]: 1 where the trained policy acts
    def act(obs, k):
      noise = jax.random.uniform(k, (obs.shape[0], base.action_size), minval=-1.0, maxval=1.0)
      return mask * run.policy(params, obs) + (1 - mask) * noise

    reset_key, action_key = jax.random.split(key)
    state = jax.vmap(env.reset)(jax.random.split(reset_key, episodes))
    _, (xy, done) = envs.rollout(env, act, state, steps, action_key,
                                 lambda s, a, nxt: (nxt.data.xpos[:, roots, :2], nxt.done))
    return xy.swapaxes(0, 1), envs.alive_before(done).swapaxes(0, 1)

  def rollouts(trained: tuple[bool, ...], key: jax.Array):
    mask = np.zeros(base.action_size, np.float32)
    for name, is_trained in zip(base.agent_names, trained):
      if is_trained:
        mask[np.asarray(base.agent_action_indices[name])] = 1.0
    xy, alive = go(jnp.asarray(mask), key)
    return np.asarray(xy), np.asarray(alive) > 0

  return rollouts


def summarise(xy: np.ndarray, alive: np.ndarray, catch_distance: float, ring: float,
              escape_distance: float = 20.0) -> dict:
  """The arm's figures (see the module doc) from ``xy [E, T, A, 2]`` and ``alive [E, T]``."""
  lengths = alive.sum(axis=1)  # steps each episode ran
  last = np.maximum(lengths - 1, 0)
  final = xy[np.arange(len(xy)), last]  # [E, A, 2]
  ended = lengths < alive.shape[1]
  dist = np.linalg.norm(final[:, 0] - final[:, 1], axis=-1)
  caught = ended & (dist < catch_distance)
  escaped = ended & (dist > escape_distance)
  radius = np.linalg.norm(final, axis=-1)  # [E, A]
  return {"episodes": int(len(xy)), "ended_early": float(ended.mean()),
          "mean_length": float(lengths.mean()), "caught": float(caught.mean()),
          "steps_to_catch": float(lengths[caught].mean()) if caught.any() else None,
          "escaped": float(escaped.mean()),
          "steps_to_escape": float(lengths[escaped].mean()) if escaped.any() else None,
          "final_distance": float(dist.mean()),
          "outside_ring": [float(x) for x in (radius > ring).mean(axis=0)]}


def main():
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("run_dir")
  parser.add_argument("--episodes", type=int, default=32)
  parser.add_argument("--steps", type=int, default=1000)
  parser.add_argument("--seed-index", type=int, default=0)
  parser.add_argument("--catch-distance", type=float, default=0.5)
  parser.add_argument("--escape-distance", type=float, default=20.0)
  parser.add_argument("--ring", type=float, default=3.0)
  parser.add_argument("--json", default=None)
  args = parser.parse_args()
  if args.episodes < 1 or args.steps < 1:
    parser.error(f"--episodes {args.episodes} and --steps {args.steps} must both be >= 1")
  run = runs.load_run(args.run_dir)
  names = list(envs.unwrap(run.env).agent_names)
  if len(names) != 2:
    parser.error(f"{args.run_dir}: a scene of {len(names)} agents {names}; this compares two")
  if not 0 <= args.seed_index < len(run.spec.seeds):
    parser.error(f"--seed-index {args.seed_index}: the run has seeds {list(run.spec.seeds)}")
  key = jax.random.PRNGKey(12345)  # the same resets and noise in every arm
  rollouts = make_rollouts(run, args.seed_index, args.episodes, args.steps)
  rows = []
  for trained in ((True, True), (True, False), (False, True), (False, False)):
    xy, alive = rollouts(trained, key)
    row = {"agent0": "trained" if trained[0] else "random",
           "agent1": "trained" if trained[1] else "random",
           **summarise(xy, alive, args.catch_distance, args.ring, args.escape_distance)}
    rows.append(row)
    print(json.dumps(row), flush=True)
  print(f"\n{run.spec.env}, seed {run.spec.seeds[args.seed_index]}, {args.episodes} episodes of at "
        f"most {args.steps} steps; jax {jax.__version__} on {jax.devices()[0].platform}")
  print(f"| {names[0]} | {names[1]} | mean length | ended early | caught | steps to catch | escaped "
        f"| steps to escape | final distance (m) | outside ring {names[0]} / {names[1]} |")
  print("| --- | --- |" + " ---: |" * 8)
  for r in rows:
    catch, escape = ("" if r[k] is None else f"{r[k]:.0f}" for k in ("steps_to_catch",
                                                                    "steps_to_escape"))
    print(f"| {r['agent0']} | {r['agent1']} | {r['mean_length']:.0f} | {r['ended_early']:.2f} "
          f"| {r['caught']:.2f} | {catch} | {r['escaped']:.2f} | {escape} "
          f"| {r['final_distance']:.2f} | {r['outside_ring'][0]:.2f} / {r['outside_ring'][1]:.2f} |")
  if args.json:
    with open(args.json, "w") as f:
      json.dump({"run": args.run_dir, "rows": rows}, f, indent=1)


if __name__ == "__main__":
  main()
