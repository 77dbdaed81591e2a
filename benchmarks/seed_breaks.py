"""Where a row's seeds broke during training (#15): per seed, the one evaluation at which a metric
worsened most, what PPO's own statistics did in that chunk, and whether the seed came back; over
the row, a window of evaluations against the last ones, paired over seeds.

    python benchmarks/seed_breaks.py METRICS_CSV --metric eval/lgr [--worse up|down]
        [--window A:B] [--last N] [--rank KEY] [--against OTHER_CSV] [--out JSON] [--plot PNG]

METRICS_CSV is a run's ``metrics.csv`` (trained with ``--eval-metrics``) or a committed row's
``NAME_metrics.csv`` under ``benchmarks/paper/``. An LGR that was not scored on the paper's goals
(the run's provenance says so, as ``paper_tables.py`` reads it) is left out, so a change of goals
never reads as a break.

- **The break** of a seed is the step between two consecutive evaluations with the largest change in
  the worse direction (``--worse``; by default up for LGRs, energy distances and conditional
  entropies, down for everything else). The seed **came back** where its last evaluation is nearer
  the value before the break than the value after it. Beside it: the chunk's ``grad_norm``,
  ``loss/value``, ``loss/policy`` and ``train/reward`` before and at the break, where the CSV has
  them, and for each the share of the breaks at which it rose against the share of all other steps
  at which it rose (its base rate), with a binomial test: a statistic that rises at every break and
  seldom elsewhere ties the breaks to PPO's updates.
- **The windows**: each seed's mean over the evaluations between A and B million env steps
  (``--window``, inclusive) against its mean over its last ``--last`` evaluations (default 10);
  a paired t-test over seeds (scipy's ``ttest_rel``) and the count of seeds that got worse.
- **The rank** (``--rank KEY``, e.g. ``grad_norm``): Spearman's rank correlation over seeds between
  KEY's mean over the window and the metric's final value, from ``eval.json`` (``NAME_eval.json``)
  beside the CSV where it holds the metric on the same goals, else the last evaluation. One row's
  seeds make it exploratory.
- **Against another run** (``--against OTHER_CSV``, with ``--window``; e.g. the same row trained
  with another setting): over the window, each seed's mean of the metric and of each PPO statistic
  and its largest worsening between two evaluations there, in this run and in the other, paired
  by seed number (the seeds both have): means, the paired t-test, Welch's t-test, and the count of
  seeds at which this run's value is the lower. The window puts both runs on the same env steps,
  so an unfinished run is compared with a finished one where both were evaluated.

Prints the tables; ``--out`` writes them as JSON, ``--plot`` one figure: the metric and
``grad_norm`` against env steps, one line per seed, each break marked.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ablations  # noqa: E402
import common  # noqa: E402
import paper_tables  # noqa: E402

# PPO's statistics read beside a break, as metrics.csv names them.
DIAGNOSTICS = ("grad_norm", "loss/value", "loss/policy", "train/reward")


def worse_direction(metric: str, worse: str | None = None) -> int:
  """+1 where a rise of ``metric`` is worse, -1 where a fall is: ``worse`` ("up" or "down") when
  given, else by the metric's name (``paper_tables.lower_is_better``: LGRs, energy distances and
  conditional entropies rise when worse)."""
  if worse is None:
    return 1 if paper_tables.lower_is_better(metric) else -1
  if worse not in ("up", "down"):
    raise ValueError(f"worse must be 'up' or 'down', got {worse!r}")
  return 1 if worse == "up" else -1


def read_rows(path: str) -> tuple[str, list[dict]]:
  """A metrics.csv's rows, with LGRs not scored on the paper's goals moved out of their keys
  (``ablations.with_lgr_goals`` with the run's provenance), and the run's name as
  ``paper_tables.logged_run`` gives it."""
  if not path.endswith("metrics.csv") or not os.path.isfile(path):
    raise ValueError(f"{path}: give a run's metrics.csv or a committed NAME_metrics.csv")
  name, _, rows, _ = paper_tables.logged_run(path)
  return name, ablations.with_lgr_goals(rows, paper_tables.run_segments(name))


def _number(row: dict, key: str) -> float | None:
  """``row[key]`` as a float; None where it is missing, empty or not finite (a chunk that logged
  NaN is no evaluation of the key)."""
  value = row.get(key)
  if value in (None, ""):
    return None
  value = float(value)
  return value if np.isfinite(value) else None


def series(rows: list[dict], metric: str) -> dict[int, list[dict]]:
  """seed -> its rows that hold ``metric``, in env-step order. Each seed needs two evaluations."""
  if not any(metric in row for row in rows):
    have = sorted({k for row in rows for k in row if k.startswith("eval/")})
    raise ValueError(f"metric {metric!r} is not in the metrics.csv; it has {', '.join(have)}")
  by_seed: dict[int, list[dict]] = {}
  for row in rows:
    if _number(row, metric) is not None:
      by_seed.setdefault(int(row["seed"]), []).append(row)
  if not by_seed:
    raise ValueError(f"no evaluation holds {metric!r} (on the paper's goals, for an LGR)")
  for seed, seed_rows in by_seed.items():
    if len(seed_rows) < 2:
      raise ValueError(f"seed {seed} has {len(seed_rows)} evaluation(s) of {metric!r}; a break "
                       "needs two")
    seed_rows.sort(key=lambda r: float(r["env_steps"]))
  return dict(sorted(by_seed.items()))


def seed_break(seed_rows: list[dict], metric: str, sign: int) -> dict | None:
  """The step between consecutive evaluations where ``metric`` changed most in the worse
  direction (``sign``), whether the last evaluation came back (nearer the value before than
  after), and the diagnostics before and at it; None for a seed whose metric never worsened."""
  values = np.array([float(r[metric]) for r in seed_rows])
  worsening = sign * np.diff(values)
  if worsening.max() <= 0:
    return None
  i = int(np.argmax(worsening)) + 1
  before, after, final = values[i - 1], values[i], values[-1]
  return {"env_steps": float(seed_rows[i]["env_steps"]),
          "env_steps_before": float(seed_rows[i - 1]["env_steps"]),
          "before": float(before), "after": float(after), "worsening": float(worsening[i - 1]),
          "final": float(final), "came_back": bool(abs(final - before) < abs(final - after)),
          "diagnostics": {key: [_number(seed_rows[i - 1], key), _number(seed_rows[i], key)]
                          for key in DIAGNOSTICS if key in seed_rows[i]}}


def rise_shares(by_seed: dict[int, list[dict]], breaks: dict) -> dict:
  """For each diagnostic: the share of the seeds' breaks at which it rose, against the share of
  all their other steps between consecutive evaluations at which it rose (the base rate), and the
  binomial test's p of that many rises at the breaks under the base rate."""
  from scipy import stats
  shares = {}
  for key in DIAGNOSTICS:
    at, elsewhere = [], []
    for seed, seed_rows in by_seed.items():
      for previous, row in zip(seed_rows, seed_rows[1:]):
        pair = _number(previous, key), _number(row, key)
        if None not in pair:
          at_break = (breaks[seed] is not None
                      and float(row["env_steps"]) == breaks[seed]["env_steps"])
          (at if at_break else elsewhere).append(pair[1] > pair[0])
    if at:
      base = float(np.mean(elsewhere)) if elsewhere else None
      # two-sided binomial test of the rises at the breaks against the base rate
      p = (stats.binomtest(int(np.sum(at)), len(at), base).pvalue
           if base is not None and 0 < base < 1 else None)
      shares[key] = {"at_breaks": float(np.mean(at)), "breaks": len(at), "elsewhere": base,
                     "steps_elsewhere": len(elsewhere), "p": p}
  return shares


def in_window(seed_rows: list[dict], key: str, window: tuple[float, float]) -> list[float]:
  """``key``'s values (``_number``) in the evaluations between ``window`` env steps (inclusive),
  in env-step order."""
  values = [_number(r, key) for r in seed_rows if window[0] <= float(r["env_steps"]) <= window[1]]
  return [v for v in values if v is not None]


def window_means(seed_rows: list[dict], key: str, window: tuple[float, float]) -> float:
  """Mean of ``key`` over the evaluations between ``window`` env steps (inclusive)."""
  values = in_window(seed_rows, key, window)
  if not values:
    raise ValueError(f"no evaluation holds {key!r} between {window[0] / 1e6:g} and "
                     f"{window[1] / 1e6:g} M env steps")
  return float(np.mean(values))


def compare_windows(by_seed: dict[int, list[dict]], metric: str, sign: int,
                    window: tuple[float, float], last: int) -> dict:
  """Each seed's mean of ``metric`` over ``window`` against its mean over its last ``last``
  evaluations: means and stds over seeds, the paired t-test and how many seeds got worse."""
  from scipy import stats
  shortest = min(len(r) for r in by_seed.values())
  if not 1 <= last <= shortest:
    raise ValueError(f"--last {last}: a seed has {shortest} evaluations; give 1 to {shortest}")
  early = np.array([window_means(r, metric, window) for r in by_seed.values()])
  late = np.array([np.mean([float(x[metric]) for x in r[-last:]]) for r in by_seed.values()])
  t, p = stats.ttest_rel(late, early) if len(early) > 1 else (float("nan"), float("nan"))
  return {"window": list(window), "last": last, "seeds": list(by_seed),
          "window_per_seed": early.tolist(), "last_per_seed": late.tolist(),
          "window_mean": float(early.mean()), "window_std": float(early.std()),
          "last_mean": float(late.mean()), "last_std": float(late.std()),
          "paired_t": float(t), "p": float(p),
          "seeds_worse": int(np.sum(sign * (late - early) > 0))}


def window_worst(seed_rows: list[dict], metric: str, sign: int,
                 window: tuple[float, float]) -> float:
  """The largest worsening of ``metric`` (``sign``: its worse direction) between consecutive
  evaluations within ``window`` env steps (inclusive); 0 where it never worsened there."""
  values = in_window(seed_rows, metric, window)
  if len(values) < 2:
    raise ValueError(f"a seed has {len(values)} evaluation(s) of {metric!r} between "
                     f"{window[0] / 1e6:g} and {window[1] / 1e6:g} M env steps; the window needs "
                     "two")
  return float(max(0.0, (sign * np.diff(values)).max()))


def against(by_seed: dict[int, list[dict]], other: dict[int, list[dict]], metric: str, sign: int,
            window: tuple[float, float]) -> dict:
  """This run (``by_seed``) against ``other`` over ``window``, paired by seed number: per row (the
  metric's mean, its largest worsening, each PPO statistic's mean that both logged), both runs'
  per-seed values, means and stds, the paired and Welch t-tests' p, and the seeds at which this
  run's value is the lower."""
  from scipy import stats
  seeds = sorted(set(by_seed) & set(other))
  if len(seeds) < 2:
    raise ValueError(f"--against: the runs share seeds {seeds}; a paired test needs two")
  measures = [(metric, lambda r: window_means(r, metric, window)),
              (f"{metric}, largest worsening", lambda r: window_worst(r, metric, sign, window))]
  measures += [(key, lambda r, key=key: window_means(r, key, window)) for key in DIAGNOSTICS
               if all(in_window(runs[s], key, window) for runs in (by_seed, other) for s in seeds)]
  out = {"window": list(window), "seeds": seeds, "rows": {}}
  for label, measure in measures:
    this = np.array([measure(by_seed[s]) for s in seeds])
    that = np.array([measure(other[s]) for s in seeds])
    paired = stats.ttest_rel(this, that)
    welch = stats.ttest_ind(this, that, equal_var=False)
    out["rows"][label] = {"this": this.tolist(), "other": that.tolist(),
                          "this_mean": float(this.mean()), "this_std": float(this.std()),
                          "other_mean": float(that.mean()), "other_std": float(that.std()),
                          "paired_t": float(paired.statistic), "paired_p": float(paired.pvalue),
                          "welch_p": float(welch.pvalue), "seeds_lower": int(np.sum(this < that))}
  return out


def final_values(name: str, metric: str, by_seed: dict[int, list[dict]]) -> tuple[list, str]:
  """Each seed's final ``metric``: from the run's eval.json where it holds the metric on the same
  goals (``ablations.final_lgr_and_balance``), else the last evaluation; and which it was."""
  for path in (f"{name}_eval.json", os.path.join(name, "eval.json")):
    if os.path.isfile(path):
      with open(path) as f:
        result = ablations.final_lgr_and_balance(json.load(f))
      values = result.get("per_seed", {}).get(metric)
      seeds = [int(s) for s in result.get("seeds", sorted(by_seed))]
      if values is not None and sorted(seeds) == list(by_seed) and len(values) == len(seeds):
        final = dict(zip(seeds, values))
        return [float(final[seed]) for seed in by_seed], path
  return [float(r[-1][metric]) for r in by_seed.values()], "the last evaluation"


def rank(by_seed: dict[int, list[dict]], key: str, window: tuple[float, float],
         finals: list[float]) -> dict:
  """Spearman's rank correlation over seeds between ``key``'s mean over ``window`` and
  ``finals``."""
  from scipy import stats
  if not any(key in row for seed_rows in by_seed.values() for row in seed_rows):
    raise ValueError(f"--rank {key!r} is not in the metrics.csv; try one of "
                     f"{', '.join(DIAGNOSTICS)}")
  means = [window_means(r, key, window) for r in by_seed.values()]
  rho, p = stats.spearmanr(means, finals)
  return {"key": key, "window_means": means, "finals": finals, "spearman": float(rho),
          "p": float(p)}


def parse_window(text: str) -> tuple[float, float]:
  """"A:B" in millions of env steps -> (A, B) in env steps."""
  try:
    low, high = (float(part) * 1e6 for part in text.split(":"))
  except ValueError:
    raise ValueError(f"--window {text!r}: give A:B in millions of env steps, e.g. 31:79") from None
  if not low <= high:
    raise ValueError(f"--window {text!r}: A must not exceed B")
  return low, high


def report(name: str, metric: str, breaks: dict, shares: dict, windows: dict | None,
           ranked: dict | None, finals_from: str | None, compared: dict | None = None,
           other_name: str | None = None) -> str:
  lines = [f"{name}: {metric}, the break of each seed (the largest worsening between two "
           "evaluations)", "",
           "| seed | between (M env steps) | before | after | final | came back | "
           + " | ".join(f"{k} before -> at" for k in DIAGNOSTICS) + " |",
           "| ---: | --- | ---: | ---: | ---: | --- |" + " --- |" * len(DIAGNOSTICS)]
  for seed, b in breaks.items():
    if b is None:
      lines.append(f"| {seed} | never worsened | | | | |" + " |" * len(DIAGNOSTICS))
      continue
    diag = [" -> ".join("-" if v is None else f"{v:.3g}" for v in b["diagnostics"].get(k, [None]))
            for k in DIAGNOSTICS]
    lines.append(f"| {seed} | {b['env_steps_before'] / 1e6:.1f} to {b['env_steps'] / 1e6:.1f} | "
                 f"{b['before']:.3f} | {b['after']:.3f} | {b['final']:.3f} | "
                 f"{'yes' if b['came_back'] else 'no'} | " + " | ".join(diag) + " |")
  if shares:
    lines += ["", "| statistic | rose at the breaks | rose at every other step (base rate) | "
              "binomial p |", "| --- | ---: | ---: | ---: |"]
    for key, v in shares.items():
      base = "-" if v["elsewhere"] is None else f"{v['elsewhere']:.0%} of {v['steps_elsewhere']}"
      p = "-" if v["p"] is None else f"{v['p']:.2g}"
      lines.append(f"| {key} | {v['at_breaks']:.0%} of {v['breaks']} | {base} | {p} |")
  if windows:
    w = windows
    lines += ["", f"| {metric} | mean ± std over seeds |", "| --- | ---: |",
              f"| {w['window'][0] / 1e6:g}-{w['window'][1] / 1e6:g} M, each seed's mean | "
              f"{w['window_mean']:.3f} ± {w['window_std']:.3f} |",
              f"| the last {w['last']} evaluations, each seed's mean | "
              f"{w['last_mean']:.3f} ± {w['last_std']:.3f} |",
              f"| paired t, p | {w['paired_t']:+.2f}, {w['p']:.3f} |",
              f"| seeds worse | {w['seeds_worse']} of {len(w['seeds'])} |"]
  if ranked:
    lines += ["", f"Spearman over seeds, {ranked['key']}'s mean over the window against the final "
              f"{metric} ({finals_from}): {ranked['spearman']:+.2f} (p {ranked['p']:.3f}); "
              "exploratory"]
  if compared:
    w, n = compared["window"], len(compared["seeds"])
    lines += ["", f"Against {other_name}, {w[0] / 1e6:g}-{w[1] / 1e6:g} M, each seed's value "
              f"there (seeds {', '.join(map(str, compared['seeds']))}):", "",
              f"| over the window | {os.path.basename(name)} | {os.path.basename(other_name)} | "
              "paired t, p | Welch p | seeds where the first is lower |",
              "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for label, v in compared["rows"].items():
      lines.append(f"| {label} | {v['this_mean']:.3f} ± {v['this_std']:.3f} | "
                   f"{v['other_mean']:.3f} ± {v['other_std']:.3f} | "
                   f"{v['paired_t']:+.2f}, {v['paired_p']:.3f} | {v['welch_p']:.3f} | "
                   f"{v['seeds_lower']} of {n} |")
  return "\n".join(lines)


def plot(path: str, name: str, metric: str, sign: int, by_seed: dict[int, list[dict]],
         breaks: dict, other: tuple[str, dict, dict] | None = None,
         window: tuple[float, float] | None = None) -> None:
  """The metric and ``grad_norm`` against env steps, a line per seed, each seed's break circled;
  with ``other`` (``(name, by_seed, breaks)`` of the run compared with), that run beside it on
  the same axes' scales, and ``window`` shaded in both."""
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  runs_ = [(name, by_seed, breaks)] + ([other] if other else [])
  keys = [metric] + (["grad_norm"] if all(
      "grad_norm" in next(iter(b.values()))[0] for _, b, _ in runs_) else [])
  fig, axes = plt.subplots(len(keys), len(runs_), figsize=(9 if not other else 14, 3.2 * len(keys)),
                           sharex=True, sharey="row", squeeze=False)
  colours = plt.get_cmap("tab10")
  for column, (run_name, run_seeds, run_breaks) in enumerate(runs_):
    for row, key in enumerate(keys):
      ax = axes[row][column]
      for n, (seed, seed_rows) in enumerate(run_seeds.items()):
        pairs = [(float(r["env_steps"]) / 1e6, _number(r, key)) for r in seed_rows]
        pairs = [(s, v) for s, v in pairs if v is not None]
        ax.plot(*zip(*pairs), color=colours(n % 10), lw=1.2, label=f"seed {seed}")
        at = run_breaks[seed] and dict(pairs).get(run_breaks[seed]["env_steps"] / 1e6)
        if at is not None:
          ax.plot(run_breaks[seed]["env_steps"] / 1e6, at, "o", color=colours(n % 10), ms=7,
                  mfc="none")
      if window and other:
        ax.axvspan(window[0] / 1e6, window[1] / 1e6, color="0.85", zorder=0)
      if column == 0:
        ax.set_ylabel(key if key != metric else
                      f"{key} ({'higher' if sign > 0 else 'lower'} is worse)")
      ax.grid(alpha=0.3)
    axes[-1][column].set_xlabel("env steps per seed (millions)")
    title = (f"{os.path.basename(run_name)}: {metric} and PPO's gradient norm per seed; "
             "circles: each seed's largest worsening" if not other else
             os.path.basename(run_name) + (" (grey: the window compared)" if window else ""))
    axes[0][column].set_title(title, fontsize=10)
  axes[0][0].legend(fontsize=7, ncol=5)
  if other:
    fig.suptitle(f"{metric} and PPO's gradient norm per seed (before any clipping); circles: each "
                 "seed's largest worsening", fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=110)
  plt.close(fig)


def main(argv=None):
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("metrics_csv")
  parser.add_argument("--metric", required=True, help="a metrics.csv column, e.g. eval/lgr")
  parser.add_argument("--worse", choices=("up", "down"),
                      help="the worse direction (default: up for LGRs, energy distances and "
                           "conditional entropies)")
  parser.add_argument("--window", help="A:B, millions of env steps: the early window")
  parser.add_argument("--last", type=int,
                      help="evaluations at the end (default 10, or each seed's count if fewer)")
  parser.add_argument("--rank", help="a statistic to rank the final metric by, e.g. grad_norm")
  parser.add_argument("--against", metavar="OTHER_CSV",
                      help="another run's metrics.csv to compare with over --window, by seed")
  parser.add_argument("--out", help="write the tables as JSON")
  parser.add_argument("--plot", help="write the figure (PNG)")
  args = parser.parse_args(argv)
  try:
    if args.rank and not args.window:
      raise ValueError("--rank needs --window, the evaluations its statistic is averaged over")
    if args.against and not args.window:
      raise ValueError("--against needs --window, the env steps both runs are compared over")
    sign = worse_direction(args.metric, args.worse)
    name, rows = read_rows(args.metrics_csv)
    by_seed = series(rows, args.metric)
    breaks = {seed: seed_break(r, args.metric, sign) for seed, r in by_seed.items()}
    shares = rise_shares(by_seed, breaks)
    window = parse_window(args.window) if args.window else None
    last = args.last or min(10, min(len(r) for r in by_seed.values()))
    windows = compare_windows(by_seed, args.metric, sign, window, last) if window else None
    ranked, finals_from = None, None
    if args.rank:
      finals, finals_from = final_values(name, args.metric, by_seed)
      ranked = rank(by_seed, args.rank, window, finals)
    compared, other = None, None
    if args.against:
      other_name, other_rows = read_rows(args.against)
      other_by_seed = series(other_rows, args.metric)
      compared = against(by_seed, other_by_seed, args.metric, sign, window)
      other = (other_name, other_by_seed,
               {seed: seed_break(r, args.metric, sign) for seed, r in other_by_seed.items()})
  except ValueError as e:
    parser.error(str(e))
  print(report(name, args.metric, breaks, shares, windows, ranked, finals_from, compared,
               other and other[0]))
  if args.out:
    common.write_json(args.out, {
        "run": name, "metric": args.metric, "worse": "up" if sign > 0 else "down",
        "breaks": breaks, "rise_shares": shares, "windows": windows,
        "rank": ranked and {**ranked, "finals_from": finals_from},
        "against": compared and {"run": other[0], **compared}})
    print(f"wrote {args.out}")
  if args.plot:
    plot(args.plot, name, args.metric, sign, by_seed, breaks, other, window)
    print(f"wrote {args.plot}")


if __name__ == "__main__":
  main()
