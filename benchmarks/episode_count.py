"""How a D-min row's energy distance depends on the number of episodes it is read from (#15): the
quick protocol's 4 (the curves logged during training by default) against the final evaluation's
10 (``eval.json``, the paper's).

    python benchmarks/episode_count.py RUN_DIR [--seeds 0,1] [--pool 40] [--sizes 1,2,4,10,20]
                                       [--draws 500] [--deterministic] [--out FILE.json]
    python benchmarks/episode_count.py RUN_DIR --plot   # episode_count.png from the JSON

Per seed, the run's final policy is rolled out as ``metrics.dmin_evaluator`` rolls it (sampled
actions unless ``--deterministic``; every 10th of the last 500 steps scored, every step in episodes
under 200 steps) for ``--pool`` episodes, and each episode's energy distance to the target and to
every other episode is taken (``metrics.energy_distance``). The energy distance of a set of
episodes read together is then exactly the mean of their distances to the target less half the
mean distance between them, each with itself included (``set_distance``), so:

- ``energy_distance/k``: what an evaluation of k episodes reads on average over every set of k of
  the pooled ones, in closed form (``expected_distance``): A - (1 - 1/k) B / 2, with
  ``episode_to_target`` A, the mean distance of one episode to the target, and
  ``between_episodes`` B, the mean distance between two different episodes;
- ``energy_distance_draws/k``, ``energy_distance_std/k``: the mean and std over ``--draws`` random
  sets of k (without replacement): the closed form's check, and how far one evaluation moves;
- ``energy_distance_pool``: every pooled episode together (``metrics.energy_distance`` on all
  their states; k = the pool);
- ``episode_mode_share/m`` (a target of several modes): the share of pooled episodes whose scored
  states are mostly nearest to mode m (``metrics.mode_shares``).

Fewer episodes lose less of B, so a policy whose episodes differ from each other (one mode per
episode, different modes in different episodes) reads higher on fewer; one whose episodes are
alike (B near 0) reads the same on any number. Between the quick protocol's 4 episodes and the
final one's 10 the gap is 0.075 B. Two point modes of equal weight at -1 and +1, each episode's
states at one of them, a pool of M split evenly: A = 1, B = 2M / (M - 1), and k episodes read
(M - k) / (k (M - 1)) on average (the test checks this).

Writes ``--out`` (default RUN_DIR/episode_count.json; ``--deterministic``:
episode_count_deterministic.json) and prints the table; ``--plot`` draws RUN_DIR/episode_count.png
from it: each seed's mean reading against k, the mean over seeds, and the quick and final
protocols' k marked.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

from blx import envs, metrics  # noqa: E402
from blx.experiments import plots, runs  # noqa: E402
from blx.objectives.specs import DminSpec  # noqa: E402

QUICK, FINAL = 4, 10  # episodes of the two protocols (blx.metrics.families)


def episode_distances(states: jax.Array, target: jax.Array) -> tuple[jax.Array, jax.Array]:
  """``(to_target [M], between [M, M])``: ``metrics.energy_distance`` of each episode of
  ``states [M, S, D]`` (M episodes of S scored states) to ``target [N, D]``, and of each pair of
  episodes to each other."""
  to_target = jax.vmap(lambda x: metrics.energy_distance(x, target))(states)
  between = jax.vmap(lambda x: jax.vmap(lambda y: metrics.energy_distance(x, y))(states))(states)
  return to_target, between


def set_distance(to_target: jax.Array, between: jax.Array, kept: jax.Array) -> jax.Array:
  """The energy distance to the target of the episodes ``kept [M]`` (0/1) hold together, from
  ``episode_distances``: the mean of their distances to the target less half the mean distance
  between them, over every ordered pair, each with itself included. Exactly what
  ``metrics.energy_distance`` reads on their pooled states (the V-statistic, equal counts per
  episode: the energy distance is a squared distance between mean embeddings, and a set's
  embedding is its episodes' mean)."""
  n = kept.sum()
  return kept @ to_target / n - 0.5 * kept @ between @ kept / n**2


def between_different(between: jax.Array) -> jax.Array:
  """B: the mean of ``between [M, M]`` over pairs of different episodes (its diagonal is 0)."""
  m = between.shape[0]
  return (between.sum() - jnp.trace(between)) / (m * (m - 1))


def expected_distance(to_target: jax.Array, between: jax.Array, size: int) -> jax.Array:
  """The mean of ``set_distance`` over every set of ``size`` (k) of the M episodes, in closed
  form: A - (1 - 1/k) B / 2, A the mean distance of an episode to the target and B
  ``between_different``. Fewer episodes lose less to B, so read higher."""
  return to_target.mean() - 0.5 * (1.0 - 1.0 / size) * between_different(between)


def subset_distances(to_target: jax.Array, between: jax.Array, size: int, draws: int,
                     key: jax.Array) -> jax.Array:
  """``set_distance`` of ``draws`` random sets of ``size`` of the M episodes, each drawn without
  replacement: ``[draws]``."""
  m = to_target.shape[0]
  if not 1 <= size <= m:
    raise ValueError(f"subset_distances: size must be 1 to the pool's {m} episodes, got {size}")

  def one(k):
    rank = jnp.argsort(jnp.argsort(jax.random.uniform(k, (m,))))
    return set_distance(to_target, between, (rank < size).astype(jnp.float32))

  return jax.vmap(one)(jax.random.split(key, draws))


def analyse(run: runs.Run, params, key: jax.Array, *, pool: int, sizes: tuple[int, ...],
            draws: int, deterministic: bool) -> dict:
  """The per-seed figures of the module's doc for one seed's ``params`` (no seed axis)."""
  spec = run.objective.spec
  indices = np.asarray(spec.obs_indices)
  target = jnp.asarray(spec.target.samples)[:, :len(indices)]
  last = metrics.scored_steps(run.env)
  every = 1 if envs.episode_steps(run.env, "episode_count") < 200 else 10
  roll_key, draw_key = jax.random.split(key)
  obs = metrics.rollout(run.env, run.policy, params, jnp.zeros((1, 0)), roll_key,
                        episodes_per_latent=pool, conditions_policy=False,
                        deterministic=deterministic,
                        record=lambda s, a, n: n.obs[..., indices])[0]       # [M, T, D]
  states = obs[:, -last:][:, ::every]                                         # [M, S, D]
  to_target, between = episode_distances(states, target)
  out = {"energy_distance_pool": metrics.energy_distance(states.reshape(-1, len(indices)),
                                                         target),
         "episode_to_target": to_target.mean(),
         "between_episodes": between_different(between)}
  for i, k in enumerate(sizes):
    ed = subset_distances(to_target, between, k, draws, jax.random.fold_in(draw_key, i))
    out[f"energy_distance/{k}"] = expected_distance(to_target, between, k)
    out[f"energy_distance_draws/{k}"] = ed.mean()
    out[f"energy_distance_std/{k}"] = ed.std()
  means = spec.target.means
  if means is not None and len(means) > 1:
    shares = metrics.mode_shares(states, jnp.asarray(means)[:, :len(indices)])
    out.update({f"episode_mode_share/{m}": shares[f"eval/episode_mode_share/{m}"]
                for m in range(len(means))})
  return out


def plot(directory: str, name: str = "episode_count.json") -> str:
  """Draws ``directory/episode_count.png`` from ``directory/NAME`` and returns its path."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  path = os.path.join(directory, name)
  if not os.path.exists(path):
    raise SystemExit(f"{path} does not exist: run `episode_count.py {directory}` first")
  with open(path) as f:
    result = json.load(f)
  sizes, v = result["sizes"], result["per_seed"]
  curves = np.array([v[f"energy_distance/{k}"] for k in sizes])           # [sizes, seeds]
  fig, ax = plt.subplots(figsize=(6.4, 4.2))
  for j in range(curves.shape[1]):
    ax.plot(sizes, curves[:, j], color="C0", alpha=0.3, lw=1,
            label="one seed (mean over every set of that many)" if j == 0 else None)
  ax.plot(sizes, curves.mean(1), color="C0", lw=2.5, marker="o", label="mean over seeds")
  pool = np.mean(v["energy_distance_pool"])
  ax.axhline(pool, color="k", ls=":", lw=1,
             label=f"all {result['pool']} episodes together ({pool:.2f})")
  for k, what in ((QUICK, "quick protocol"), (FINAL, "final protocol")):
    ax.axvline(k, color="C3" if k == QUICK else "C2", ls="--", lw=1,
               label=f"{what}: {k} episodes")
  ax.set_xscale("log")
  ax.set_xticks(sizes, [str(k) for k in sizes])
  ax.set_xlabel("episodes the energy distance is read from")
  ax.set_ylabel("energy distance (lower is better)")
  ax.grid(alpha=0.3)
  ax.legend(fontsize=8)
  spec = runs.read_spec(directory)
  label = common.run_label(spec, directory=directory)
  ax.set_title(plots.fit_title(f"{label}: the same policies read\nfrom fewer "
                                f"or more episodes (of {result['pool']} per seed)", fig),
               fontsize=10)
  fig.tight_layout()
  out = os.path.join(directory, "episode_count.png")
  fig.savefig(out, dpi=120)
  plt.close(fig)
  return out


def main(argv=None) -> int:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  common.add_analysis_arguments(parser, "a finished D-min run directory (config.json and "
                                "checkpoint)")
  parser.add_argument("--pool", type=int, default=40, help="episodes rolled out per seed")
  parser.add_argument("--sizes", default="1,2,4,10,20",
                      help="comma-separated numbers of episodes to read (each at most --pool)")
  parser.add_argument("--draws", type=int, default=500, help="random sets per size")
  parser.add_argument("--plot", action="store_true",
                      help="only draw episode_count.png from the JSON")
  args = parser.parse_args(argv)
  name = "episode_count_deterministic.json" if args.deterministic else "episode_count.json"
  if args.plot:
    print(f"wrote {plot(args.run, name)}")
    return 0
  try:
    sizes = tuple(sorted({int(k) for k in args.sizes.split(",")}))
  except ValueError:
    parser.error(f"--sizes takes comma-separated whole numbers, got {args.sizes!r}")
  if args.pool < 2 or args.draws < 1:
    parser.error(f"--pool must be at least 2 and --draws at least 1, got {args.pool} and "
                 f"{args.draws}")
  if sizes[0] < 1 or sizes[-1] > args.pool:
    parser.error(f"--sizes must lie in 1 to --pool ({args.pool}), got {args.sizes}")
  run = runs.load_run(args.run)
  if not isinstance(run.objective.spec, DminSpec):
    parser.error(f"{args.run}: {run.spec.objective} is not a D-min objective; this analysis reads "
                 "the energy distance")
  n = len(run.spec.seeds)
  try:
    picked = common.seed_positions(args.seeds, n)
  except ValueError as e:
    parser.error(str(e))
  params, keys = common.picked_seeds(run, picked, 2)
  one = lambda p, k: analyse(run, p, k, pool=args.pool, sizes=sizes, draws=args.draws,
                             deterministic=args.deterministic)
  values = {k: np.asarray(v).tolist() for k, v in jax.jit(jax.vmap(one))(params, keys).items()}
  result = {"run": os.path.abspath(args.run), "seeds": [run.spec.seeds[p] for p in picked],
            "deterministic": args.deterministic, "pool": args.pool, "sizes": list(sizes),
            "draws": args.draws, "per_seed": values}
  out = args.out or os.path.join(args.run, name)
  common.write_json(out, result)
  print(f"{run.spec.objective} on {run.spec.env}, seeds {result['seeds']}, {args.pool} episodes "
        f"per seed, {args.draws} draws per size")
  print("| episodes | energy distance: over every set (closed form) | mean of the draws | "
        "std over draws |\n| ---: | ---: | ---: | ---: |")
  for k in sizes:
    mean = np.asarray(values[f"energy_distance/{k}"])
    drawn = np.asarray(values[f"energy_distance_draws/{k}"])
    spread = np.asarray(values[f"energy_distance_std/{k}"])
    print(f"| {k} | {mean.mean():.3f} +- {mean.std():.3f} | {drawn.mean():.3f} | "
          f"{spread.mean():.3f} |")
  pool = np.asarray(values["energy_distance_pool"])
  print(f"| all {args.pool} | {pool.mean():.3f} +- {pool.std():.3f} | | |")
  for name in ("episode_to_target", "between_episodes"):
    print(f"{name}: {np.mean(values[name]):.3f} +- {np.std(values[name]):.3f}")
  print(f"wrote {out}")
  return 0


if __name__ == "__main__":
  raise SystemExit(main())
