"""How far a GCRL row's skills reach toward their goals, as its MI and H(s) imply under a model of
their states (#15). A reading of the paper's numbers and blx's beside them, not an experiment.

    python benchmarks/goal_reach_model.py [EVAL_JSON | RUN_DIR] [--env ENV] [--dims D]
        [--obs-scale 5] [--latents N] [--episodes N] [--steps 500] [--draws 20] [--out FILE.json]
    python benchmarks/goal_reach_model.py [EVAL_JSON | RUN_DIR] --predict FORM:REACH:SIGMA ...
    python benchmarks/goal_reach_model.py EVAL_JSON --measured GOAL_REACHING_JSON [--neighbours 1]

GCRL's latents are goals g ~ U(-s/2, s/2)^D (s = obs_scale, Braxlines' prior), and the paper's
evaluation (Algorithm 1) bins, for each of ``--latents`` goals, ``--episodes`` x ``--steps`` states
of the goal feature: 1000 bins over [-s, s] per dimension, the entropies averaged over dimensions.
The model draws every state of goal g as m(g) + sigma * N(0, I), where m(g) is what the skill
reaches of its goal. Two forms of it:
- ``cap``: g shortened to a length of at most ``reach`` (a top speed, for a velocity goal);
- ``fraction``: ``reach`` * g (the skill goes the goal's way, a fixed share of the distance).

sigma alone sets H(s|z), how widely one skill's states spread; ``reach`` then sets how far apart
the skills' states lie, and so H(s). For a row's mean H(s) and H(s|z) (the paper's H(s|z) is its
H(s) less its MI) the script finds the sigma and the reach that give them, with the estimator of
``blx.metrics.particle`` and the same draws for every candidate, by bisection. For EVAL_JSON (a
finished GCRL row's ``eval.json``) it fits the row's mean and every seed; the paper's row comes from
``paper_tables.PAPER``. For RUN_DIR (a GCRL run that logs the paper's metrics while it trains,
``--eval-metrics``) it reads the run's last evaluation that every seed reached (``run_row``). The
model draws as many goals and episodes as the evaluation it reads took (``--latents``,
``--episodes``; by default its protocol's, ``blx.metrics.families.ROLLOUTS``: 10 and 10 for an
eval.json, 4 and 4 for a run's quick evaluations), since the estimator reads other values from
other sizes. The paper's row is fitted at the same sizes, which are not the paper's own where they
are quick: compare a quick evaluation's fit with the paper's at the protocol's sizes.

``--measured GOAL_REACHING_JSON`` reads the skills as measured instead: per seed, each model goal's
mean state is that of the nearest latent ``goal_reaching.py`` rolled out (``--neighbours K``: the
inverse-distance mean of the K nearest), its spread the sigma fitted to EVAL_JSON's H(s|z); it
prints the H(s) and MI that gives beside the evaluation's, seed by seed. It tests the cap and the
fraction, which give every direction one reach, against the skills' own.

``--predict FORM:REACH:SIGMA`` (repeatable; e.g. ``cap:2.19:0.3``, a top speed measured by
``goal_reaching.py``'s ``farthest``, or ``fraction:0.83:0.3``, its ``goal_share``) turns the model
around: it scores those states at the sizes drawn (``--latents`` x ``--episodes``; by default the
protocol's of EVAL_JSON, else the final evaluation's 10 x 10) and prints the H(s), H(s|z) and MI
they give, beside the paper's row and EVAL_JSON's, without fitting: a forecast to test against an
evaluation not yet run.

What the model leaves out: a real skill's states are not independent draws (a stride, a drift
within an episode, episodes that differ), and its reach need not be the same for every goal. So
its sigma and reach are the simplest states that score what a row scores, a scale to read the
row's numbers in (m/s, for the Ant's velocity goals), not a measurement of its skills. Runs on a
CPU in about a minute.
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
import ablations  # noqa: E402
import common  # noqa: E402
import paper_tables  # noqa: E402

from blx.experiments import runs  # noqa: E402
from blx.metrics import particle  # noqa: E402
from blx.metrics.families import ROLLOUTS  # noqa: E402

MODELS = ("cap", "fraction")
BINS = 1000


def reached(goals: np.ndarray, reach: float, model: str) -> np.ndarray:
  """m(g) for goals ``[..., D]``: ``cap`` shortens each goal to a length of at most ``reach``,
  ``fraction`` scales it by ``reach``."""
  if model == "cap":
    length = np.linalg.norm(goals, axis=-1, keepdims=True)
    return goals * np.minimum(1.0, reach / np.maximum(length, 1e-12))
  if model == "fraction":
    return reach * goals
  raise ValueError(f"model {model!r}: the models are {', '.join(MODELS)}")


class Model:
  """The model's states for fixed draws: ``draws`` evaluations of ``latents`` goals, each with
  ``samples`` states (``episodes`` x ``steps``), scored as the paper scores a row."""

  def __init__(self, *, dims: int = 2, obs_scale: float = 5.0, latents: int = 10,
               samples: int = 5000, draws: int = 20, seed: int = 0):
    if min(dims, latents, samples, draws) < 1 or obs_scale <= 0:
      raise ValueError(f"dims {dims}, latents {latents}, samples {samples}, draws {draws} and "
                       f"obs_scale {obs_scale} must all be positive")
    rng = np.random.default_rng(seed)
    self.obs_scale = obs_scale
    self.goals = rng.uniform(-obs_scale / 2, obs_scale / 2, (draws, latents, 1, dims))
    self.noise = rng.standard_normal((draws, latents, samples, dims)).astype(np.float32)
    labels = jnp.repeat(jnp.arange(latents), samples)

    def score(states):  # [L, S, D] -> (H(s), H(s|z)), each averaged over the dimensions
      mi = particle.mutual_information(states.reshape(-1, dims), labels, bins=BINS,
                                       value_range=(-obs_scale, obs_scale), num_labels=latents)
      return mi["entropy"].mean(), mi["conditional_entropy"].mean()

    self._score = jax.jit(jax.vmap(score))

  def __call__(self, reach: float, sigma: float, model: str = "cap") -> tuple[float, float]:
    """(H(s), H(s|z)), each the mean over the draws."""
    states = reached(self.goals, reach, model) + sigma * self.noise
    h, hz = self._score(jnp.asarray(states, jnp.float32))
    return float(h.mean()), float(hz.mean())

  def score_means(self, means: np.ndarray, sigma: float) -> tuple[float, float]:
    """(H(s), H(s|z)) of states drawn about given mean states ``means`` (``[draws, latents, 1,
    dims]``, one per goal of ``self.goals``), each the mean over the draws."""
    h, hz = self._score(jnp.asarray(means + sigma * self.noise, jnp.float32))
    return float(h.mean()), float(hz.mean())

  def most_reach(self, model: str) -> float:
    """The reach beyond which the model changes nothing: every goal reached whole (``cap``: the
    box's corner; ``fraction``: the goal itself, a share of 1)."""
    dims = self.goals.shape[-1]
    return self.obs_scale / 2 * np.sqrt(dims) if model == "cap" else 1.0


def measured_means(goals: np.ndarray, candidates: np.ndarray, candidate_means: np.ndarray,
                   neighbours: int = 1) -> np.ndarray:
  """m(g) read off measured skills: for goals ``[..., D]``, the mean states ``candidate_means
  [C, D]`` that ``goal_reaching.py`` measured under the latents ``candidates [C, D]``, averaged
  over the ``neighbours`` candidates nearest each goal, weighted by inverse distance (a candidate
  at the goal itself takes all the weight)."""
  distance = np.linalg.norm(goals[..., None, :] - candidates, axis=-1)  # [..., C]
  k = min(neighbours, candidates.shape[0])
  nearest = np.argsort(distance, -1)[..., :k]
  d = np.take_along_axis(distance, nearest, -1)
  weight = np.where(d[..., :1] < 1e-9, (d < 1e-9).astype(float), 1.0 / np.maximum(d, 1e-9))
  weight = weight / weight.sum(-1, keepdims=True)
  return (candidate_means[nearest] * weight[..., None]).sum(-2)


def measured(model: Model, reaching: dict, sigma: float, neighbours: int = 1) -> dict:
  """Per seed of a ``goal_reaching.py`` JSON (``reaching``), the model's H(s), H(s|z) and MI with
  its skills' measured mean states (``measured_means``) in place of the cap or the fraction, and
  spread ``sigma``: whether the reach as measured, direction by direction, scores what the row
  does. ``{"seeds": [...], "entropy": [...], "conditional_entropy": [...], "mi": [...]}``."""
  out = {"seeds": [], "entropy": [], "conditional_entropy": [], "mi": []}
  for seed, row in reaching["per_seed"].items():
    candidates = np.asarray(row["candidates"], np.float64)
    if candidates.shape[-1] != model.goals.shape[-1]:
      raise ValueError(f"seed {seed}'s candidates have {candidates.shape[-1]} dimensions, the "
                       f"model's goals {model.goals.shape[-1]}")
    means = measured_means(model.goals, candidates, np.asarray(row["candidate_means"]),
                           neighbours)
    h, hz = model.score_means(means, sigma)
    for key, value in (("seeds", seed), ("entropy", h), ("conditional_entropy", hz),
                       ("mi", h - hz)):
      out[key].append(value)
  return out


def _bisect(f, target: float, lo: float, hi: float, iterations: int = 20) -> float:
  """x in [lo, hi] where the increasing ``f`` crosses ``target`` (lo or hi where it does not)."""
  if f(lo) >= target:
    return lo
  if f(hi) <= target:
    return hi
  for _ in range(iterations):
    mid = 0.5 * (lo + hi)
    lo, hi = (mid, hi) if f(mid) < target else (lo, mid)
  return 0.5 * (lo + hi)


def _sigmas(model: Model) -> tuple[float, float]:
  """The sigmas a fit searches: up to obs_scale / 5 the states stay within the estimator's range
  (5 sigma) and H(s|z) grows with sigma; beyond, states fall outside it and H(s|z) shrinks again."""
  return 1e-3, model.obs_scale / 5


def fit_sigma(model: Model, conditional_entropy: float, form: str = "cap") -> float:
  """The sigma whose skills, at no reach, score ``conditional_entropy``."""
  return _bisect(lambda s: model(0.0, s, form)[1], conditional_entropy, *_sigmas(model))


def fit(model: Model, entropy: float, conditional_entropy: float, form: str = "cap") -> dict:
  """The sigma whose skills score ``conditional_entropy`` (at no reach), then the reach that, with
  it, scores ``entropy``. ``reach_bound`` says where the target lies beyond the model's range
  ("above": every goal reached whole still scores less H(s); "below": skills at the origin
  already score more). The same for ``sigma_bound`` and H(s|z)."""
  sigmas = _sigmas(model)
  sigma = fit_sigma(model, conditional_entropy, form)
  reaches = (0.0, model.most_reach(form))
  reach = _bisect(lambda r: model(r, sigma, form)[0], entropy, *reaches)
  h, hz = model(reach, sigma, form)
  return {"sigma": sigma, "sigma_bound": _bound(sigma, hz, conditional_entropy, *sigmas),
          "reach": reach, "reach_bound": _bound(reach, h, entropy, *reaches),
          "entropy": h, "conditional_entropy": hz}


def _bound(x: float, value: float, target: float, lo: float, hi: float) -> str:
  """Whether the target lies beyond the bisection's interval: "above" (x at hi, still short of the
  target), "below" (x at lo, already past it), or ""."""
  tolerance = 1e-3
  if x >= hi and value < target - tolerance:
    return "above"
  if x <= lo and value > target + tolerance:
    return "below"
  return ""


def row_dims(eval_json: dict) -> int:
  """The goal's dimensions in a row's ``eval.json``: its per-dimension MI, one a dimension."""
  return sum(k.startswith("eval/mi_1d/") for k in eval_json["summary"])


def row_means(eval_json: dict) -> tuple[dict, list[dict]]:
  """The row's mean H(s) and H(s|z), and each seed's, from a GCRL row's ``eval.json``."""
  if eval_json.get("objective") != "gcrl":
    raise ValueError(f"the model is GCRL's (goals drawn from a box); this eval.json is of "
                     f"{eval_json.get('objective')!r}")
  summary, per_seed = eval_json["summary"], eval_json["per_seed"]
  keys = ("eval/entropy", "eval/conditional_entropy")
  missing = [k for k in keys if k not in summary or k not in per_seed]
  if missing:
    raise ValueError(f"the eval.json lacks {missing}; it needs H(s) and H(s|z)")
  mean = {k: summary[k]["mean"] for k in keys}
  seeds = [dict(zip(keys, v)) for v in zip(*(per_seed[k] for k in keys))]
  return mean, seeds


def run_row(directory: str) -> dict:
  """The last evaluation that every seed of the run in ``directory`` reached (its H(s), H(s|z) and
  per-dimension MI, logged with ``--eval-metrics``), as ``row_means`` reads an eval.json, with its
  ``env_steps`` and ``eval_protocol`` (the rollouts it took: the one its provenance records, else
  "quick", as training logged before provenance named it). Raises ValueError for a directory
  without one run's metrics.csv, or whose runs logged no H(s|z)."""
  found = paper_tables.logged(directory)
  if len(found) != 1:
    raise ValueError(f"{len(found)} runs under {directory}: give one run's directory")
  name, config, rows, _ = found[0]
  if isinstance(config, str):
    raise ValueError(config)
  keys = ["eval/entropy", "eval/conditional_entropy",
          *sorted(k for k in (rows[0] if rows else {}) if k.startswith("eval/mi_1d/"))]
  values = {key: ablations.by_step(rows, key) for key in keys}
  steps = ablations.complete_steps(values["eval/conditional_entropy"])
  if not steps:
    raise ValueError(f"{name}'s metrics.csv has no evaluation with H(s|z) (train with "
                     "--eval-metrics)")
  last = steps[-1]
  seeds = sorted(values["eval/conditional_entropy"][last])
  per_seed = {key: [by[last][s] for s in seeds] for key, by in values.items()
              if set(by.get(last, {})) == set(seeds)}
  segment = runs.segment_at(paper_tables.run_segments(name), last)
  return {"env": config["env"], "objective": config["objective"], "env_steps": last,
          "eval_protocol": (segment and segment.eval_protocol) or "quick", "per_seed": per_seed,
          "summary": {key: {"mean": float(np.mean(v))} for key, v in per_seed.items()}}


def prediction(text: str) -> tuple[str, float, float]:
  """``FORM:REACH:SIGMA`` as ``(form, reach, sigma)``; ValueError naming what is wrong."""
  parts = text.split(":")
  if len(parts) != 3:
    raise ValueError(f"--predict {text!r}: give FORM:REACH:SIGMA, e.g. cap:2.19:0.3")
  form, *numbers = parts
  if form not in MODELS:
    raise ValueError(f"--predict {text!r}: the form {form!r} is not one of {', '.join(MODELS)}")
  try:
    reach, sigma = (float(n) for n in numbers)
  except ValueError:
    raise ValueError(f"--predict {text!r}: REACH and SIGMA must be numbers") from None
  if reach < 0 or sigma <= 0:
    raise ValueError(f"--predict {text!r}: REACH must be 0 or more and SIGMA more than 0")
  return form, reach, sigma


def predict(model: Model, predictions: list[tuple[str, float, float]]) -> list[dict]:
  """The model's H(s), H(s|z) and MI for each ``(form, reach, sigma)``."""
  out = []
  for form, reach, sigma in predictions:
    h, hz = model(reach, sigma, form)
    out.append({"form": form, "reach": reach, "sigma": sigma, "entropy": h,
                "conditional_entropy": hz, "mi": h - hz})
  return out


def main(argv=None):
  parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
  parser.add_argument("eval_json", nargs="?", default=None, metavar="EVAL_JSON | RUN_DIR",
                      help="a finished GCRL row's eval.json, or a GCRL run's directory (its last "
                      "evaluation during training) (default: the paper's row alone)")
  parser.add_argument("--env", choices=paper_tables.ENVS, default=None,
                      help="the paper's row to read (default: the eval.json's env, else ant)")
  parser.add_argument("--dims", type=int, default=None,
                      help="the goal's dimensions (default: the eval.json's, else 2: the xy "
                      "velocity of the Ant and the Humanoid; the HalfCheetah's x velocity is 1)")
  parser.add_argument("--obs-scale", type=float, default=5.0)
  parser.add_argument("--latents", type=int, default=None,
                      help="goals per evaluation (default: the evaluation's protocol's)")
  parser.add_argument("--episodes", type=int, default=None,
                      help="episodes per goal (default: the evaluation's protocol's)")
  parser.add_argument("--steps", type=int, default=500, help="scored states per episode")
  parser.add_argument("--draws", type=int, default=20, help="evaluations the model averages")
  parser.add_argument("--predict", action="append", default=[], metavar="FORM:REACH:SIGMA",
                      help="score these states instead of fitting (repeatable), e.g. "
                      "cap:2.19:0.3 or fraction:0.83:0.3")
  parser.add_argument("--measured", default=None, metavar="GOAL_REACHING_JSON",
                      help="score the skills' mean states as goal_reaching.py measured them (its "
                      "JSON, of EVAL_JSON's run), per seed, beside EVAL_JSON's")
  parser.add_argument("--neighbours", type=int, default=1,
                      help="with --measured: a goal's mean state is that of its nearest measured "
                      "skill (1), or the inverse-distance mean of this many nearest")
  parser.add_argument("--out", default=None, help="write the fits as JSON here")
  args = parser.parse_args(argv)
  if args.neighbours < 1:
    parser.error(f"--neighbours {args.neighbours}: give 1 or more")
  if args.measured and not args.eval_json:
    parser.error("--measured needs EVAL_JSON (or RUN_DIR): the evaluation to set the measured "
                 "skills beside")
  if args.measured and args.predict:
    parser.error("--measured and --predict are two readings; give one")
  try:
    predictions = [prediction(p) for p in args.predict]
  except ValueError as e:
    parser.error(str(e))
  rows, row, scored = {}, None, 0
  if args.eval_json:
    try:
      if os.path.isdir(args.eval_json):
        row = run_row(args.eval_json)
      else:
        with open(args.eval_json) as f:
          row = json.load(f)
      rows["blx"] = row_means(row)
    except (OSError, ValueError, KeyError) as e:
      parser.error(f"{args.eval_json}: {e}")
    if args.env and row.get("env") and args.env != row["env"]:
      parser.error(f"--env {args.env}, but {args.eval_json} is a {row['env']} row; the paper's "
                   "row must be of the same body")
    scored = row_dims(row)
    if args.dims and scored and args.dims != scored:
      parser.error(f"--dims {args.dims}, but {args.eval_json} scored {scored} dimensions")
    if not (args.dims or scored):
      parser.error(f"{args.eval_json} has no per-dimension MI (eval/mi_1d/...) to count the "
                   "goal's dimensions by; give --dims")
  args.env = args.env or (row or {}).get("env", "ant")
  args.dims = args.dims or scored or 2
  protocol = (row or {}).get("eval_protocol", "final")  # an eval.json's: the final evaluation's
  args.latents = ROLLOUTS[protocol] if args.latents is None else args.latents
  args.episodes = ROLLOUTS[protocol] if args.episodes is None else args.episodes
  evaluation = ({"env_steps": row["env_steps"], "eval_protocol": protocol}
                if row and "env_steps" in row else None)  # a run's, during training (run_row)
  if evaluation:
    print(f"{args.eval_json}: its evaluation at {row['env_steps'] / 1e6:.1f} M env steps per "
          f"seed, {protocol} ({ROLLOUTS[protocol]} goals x {ROLLOUTS[protocol]} episodes); the "
          f"model draws {args.latents} x {args.episodes}\n")
  paper = paper_tables.PAPER.get(args.env, {}).get("gcrl")
  if paper is None:
    parser.error(f"the paper has no GCRL row for {args.env!r}")
  rows = {"paper": ({"eval/entropy": paper["eval/entropy"][0],
                     "eval/conditional_entropy": paper["eval/entropy"][0] - paper["eval/mi"][0]},
                    []), **rows}
  try:
    model = Model(dims=args.dims, obs_scale=args.obs_scale, latents=args.latents,
                  samples=args.episodes * args.steps, draws=args.draws)
  except ValueError as e:
    parser.error(str(e))
  out = {"env": args.env, "dims": args.dims, "obs_scale": args.obs_scale,
         "latents": args.latents, "samples_per_latent": args.episodes * args.steps,
         "draws": args.draws, "rows": {}}
  if evaluation:
    out["evaluation"] = evaluation
  if args.measured:
    try:
      with open(args.measured) as f:
        reaching = json.load(f)
      evaluated = [str(seed) for seed in row.get("seeds", [])]
      if evaluated and list(reaching["per_seed"]) != evaluated:
        raise ValueError(f"it measured seeds {list(reaching['per_seed'])}, the evaluation's are "
                         f"{evaluated}: measure the evaluation's seeds, in its order")
      sigma = fit_sigma(model, rows["blx"][0]["eval/conditional_entropy"])
      out["measured"] = {"sigma": sigma, "neighbours": args.neighbours,
                         **measured(model, reaching, sigma, args.neighbours)}
      table = measured_table(out["measured"], rows["blx"][1])
    except (OSError, ValueError, KeyError) as e:
      parser.error(f"--measured {args.measured}: {e}")
    print(table)
    if args.out:
      common.write_json(args.out, out)
    return
  if predictions:
    out["predictions"] = predict(model, predictions)
    print(f"the model at {args.latents} goals x {args.episodes} episodes x {args.steps} states:\n")
    print("| states | H(s) | H(s\\|z) | MI |")
    print("| --- | ---: | ---: | ---: |")
    for p in out["predictions"]:
      states = (f"cap at {p['reach']:g}" if p["form"] == "cap" else
                f"{p['reach']:g} of each goal") + f", sigma {p['sigma']:g}"
      print(f"| {states} | {p['entropy']:.3f} | {p['conditional_entropy']:.3f} | {p['mi']:.3f} |")
    for name, (mean, _) in rows.items():
      h, hz = mean["eval/entropy"], mean["eval/conditional_entropy"]
      out["rows"][name] = {"entropy": h, "conditional_entropy": hz}
      print(f"| {name}, measured | {h:.3f} | {hz:.3f} | {h - hz:.3f} |")
    if args.out:
      common.write_json(args.out, out)
    return
  bound = {"above": "at least ", "below": "at most "}
  print("| row | H(s) | H(s\\|z) | MI | model | sigma | reach |")
  print("| --- | ---: | ---: | ---: | --- | ---: | ---: |")
  for name, (mean, seeds) in rows.items():
    h, hz = mean["eval/entropy"], mean["eval/conditional_entropy"]
    entry = out["rows"][name] = {"entropy": h, "conditional_entropy": hz, "fits": {}}
    for form in MODELS:
      fitted = fit(model, h, hz, form)
      per_seed = [fit(model, s["eval/entropy"], s["eval/conditional_entropy"], form)["reach"]
                  for s in seeds]
      entry["fits"][form] = {**fitted, "reach_per_seed": per_seed}
      spread = f" ({np.mean(per_seed):.2f} ± {np.std(per_seed):.2f} over seeds)" if seeds else ""
      print(f"| {name} | {h:.3f} | {hz:.3f} | {h - hz:.3f} | {form} | "
            f"{bound.get(fitted['sigma_bound'], '')}{fitted['sigma']:.3f} | "
            f"{bound.get(fitted['reach_bound'], '')}{fitted['reach']:.2f}{spread} |")
  if "blx" in out["rows"]:
    out["swapped"] = swapped(model, out["rows"]["paper"]["fits"], out["rows"]["blx"]["fits"])
    print("\nMI of the model with one part of blx's fit and the other of the paper's:")
    print("| model | blx | blx's sigma, the paper's reach | the paper's sigma, blx's reach | paper |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for form, mi in out["swapped"].items():
      print(f"| {form} | {mi['blx']:.3f} | {mi['blx_sigma_paper_reach']:.3f} | "
            f"{mi['paper_sigma_blx_reach']:.3f} | {mi['paper']:.3f} |")
  if args.out:
    common.write_json(args.out, out)


def measured_table(reading: dict, seeds: list[dict]) -> str:
  """``measured``'s reading beside the evaluation's per-seed values ``seeds`` (``row_means``'),
  seed by seed, with the means and the mean difference in H(s)."""
  lines = [f"the model with the skills' measured mean states, sigma {reading['sigma']:.3f} (fitted "
           "to the evaluation's H(s|z)), against the evaluation:", "",
           "| seed | H(s), model | H(s), evaluation | MI, model | MI, evaluation |",
           "| --- | ---: | ---: | ---: | ---: |"]
  if len(seeds) != len(reading["seeds"]):
    raise ValueError(f"the evaluation has {len(seeds)} seeds, the measurement "
                     f"{len(reading['seeds'])}")
  for seed, h, mi, row in zip(reading["seeds"], reading["entropy"], reading["mi"], seeds):
    observed = row["eval/entropy"] - row["eval/conditional_entropy"]
    lines.append(f"| {seed} | {h:.3f} | {row['eval/entropy']:.3f} | {mi:.3f} | {observed:.3f} |")
  model_h = np.asarray(reading["entropy"])
  seen_h = np.asarray([row["eval/entropy"] for row in seeds])
  model_mi = np.asarray(reading["mi"])
  seen_mi = seen_h - np.asarray([row["eval/conditional_entropy"] for row in seeds])
  lines.append(f"| mean | {model_h.mean():.3f} | {seen_h.mean():.3f} | {model_mi.mean():.3f} | "
               f"{seen_mi.mean():.3f} |")
  diff = model_h - seen_h
  lines += ["", f"H(s), model less evaluation: {diff.mean():+.3f} ± {diff.std():.3f} over seeds"]
  return "\n".join(lines)


def swapped(model: Model, paper: dict, blx: dict) -> dict:
  """Per model form, the model's MI with both fits' sigma and reach, and with each swapped: how
  much of the MI gap the reach accounts for, and how much the spread."""
  out = {}
  for form in MODELS:
    mi = lambda reach, sigma: float(np.subtract(*model(reach, sigma, form)))
    p, b = paper[form], blx[form]
    out[form] = {"blx": mi(b["reach"], b["sigma"]), "paper": mi(p["reach"], p["sigma"]),
                 "blx_sigma_paper_reach": mi(p["reach"], b["sigma"]),
                 "paper_sigma_blx_reach": mi(b["reach"], p["sigma"])}
  return out


if __name__ == "__main__":
  main()
