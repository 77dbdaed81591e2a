"""The plots of a run directory (matplotlib, headless): training curves, skills, D-min density and
discriminator maps."""

from __future__ import annotations

import dataclasses
import os
import re
import textwrap
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from blx import envs, metrics, training
from blx.training.config import off_row_text

__all__ = ["training_curves", "skills", "paths", "draw_paths", "root_body", "root_xy", "density",
           "discriminator", "write_all", "fit_title"]

# The episode length follows the totals: an episode cut short by a fall sums fewer steps.
CURVE_PATTERNS = (r"^eval/episode_reward$", r"^eval/episode_score$", r"^eval/episode_length$",
                  r"^eval/mi$", r"^eval/entropy$", r"^eval/lgr$", r"^eval/energy_distance$",
                  r"^eval/mode_share/\d+$", r"^loss/disc$", r"^disc/accuracy$", r"^loss/policy$",
                  r"^policy/entropy$", r"^grad_norm$", r"^grad_clipped$")
PER_AGENT = ("eval/episode_reward", "eval/episode_score")  # split by agent in multi-agent runs


def _pyplot():
  import matplotlib
  matplotlib.use("Agg")
  import matplotlib.pyplot as plt
  return plt


def curve_titles(keys, objective) -> dict[str, str]:
  """Panel titles: the key, and for ``eval/mode_share/k`` of a D-min objective the mode it counts
  (``eval/mode_share/0: nearest (4, 0)``), from the target's means."""
  means = getattr(getattr(getattr(objective, "spec", None), "target", None), "means", None)
  titles = {}
  for key in keys:
    match = re.match(r"^eval/(episode_)?mode_share/(\d+)$", key)
    if match and means is not None and int(match.group(2)) < len(means):
      mode = ", ".join(f"{v:g}" for v in np.round(np.asarray(means[int(match.group(2))]), 2) + 0.0)
      titles[key] = f"{key}: nearest ({mode})"
    else:
      titles[key] = key
  return titles


# What a training-curve panel's y axis measures.
YLABELS = {
    "eval/episode_reward": "objective's reward per episode",
    "eval/episode_score": "env's score per episode",
    "eval/episode_length": "env steps per episode",
    "eval/mi": "MI(s; z) (nats)",
    "eval/entropy": "H(s) (nats)",
    "eval/lgr": "LGR (distance to goal)",
    "eval/energy_distance": "energy distance to target",
    "loss/disc": "discriminator loss",
    "disc/accuracy": "discriminator accuracy",
    "loss/policy": "PPO policy loss",
    "policy/entropy": "policy entropy (nats)",
    "grad_norm": "gradient norm (before any clip)",
    "grad_clipped": "share of SGD steps clipped",
}


def fit_title(text: str, fig, fontsize: float = 10) -> str:
  """``text`` with each of its lines wrapped to the width of the figure ``fig`` at ``fontsize``
  points (a character taken as 0.6 em), so that a long run label (env edits, PPO options) stays on
  the figure."""
  chars = max(20, int(fig.get_size_inches()[0] * 72 / (0.6 * fontsize)))
  return "\n".join(textwrap.fill(line, chars) for line in text.split("\n"))


def _steps_formatter():
  from matplotlib.ticker import FuncFormatter

  def fmt(x, _):
    for div, unit in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
      if abs(x) >= div:
        return f"{x / div:g}{unit}"
    return f"{x:g}"
  return FuncFormatter(fmt)


# Curves of a count, an episode's length, are drawn from 0: a run whose episodes all last to the
# end is then a flat line at the episode length, not one short episode magnified to fill the panel.
FROM_ZERO = ("eval/episode_length", "eval/mode_balance", "grad_clipped")


def value_axis(ax, key: str) -> None:
  """Sets a curve panel's y axis, once its curves are drawn: tick labels are the values themselves
  (no "+1e3" offset above the axis) and a count (``FROM_ZERO``) is drawn from 0."""
  ax.ticklabel_format(axis="y", useOffset=False)
  if key in FROM_ZERO:
    top = max(ax.get_ylim()[1], 0.0)
    ax.set_ylim(0.0, 1.05 * top if top > 0 else 1.0)


def curve_ylabel(key: str) -> str:
  """The y-axis label of a training-curve panel."""
  if re.match(r"^eval/mode_share/\d+$", key):
    return "share of samples"
  if re.match(r"^eval/episode_mode_share/\d+$", key):
    return "share of episodes"
  return YLABELS.get(key, key.rsplit("/", 1)[-1].replace("_", " "))


def band_caption(num_seeds: int, keys: Sequence[str] = (), eval_actions: str | None = None) -> str:
  """What the line and the band of a training curve are, and how the panels of ``keys`` were
  measured: the trainer's evaluation episodes (acting as ``eval_actions``, the run's
  ``PPOConfig.eval_actions``, says; None: not said), the evaluator's sampled ones, or training."""
  spread = (f"line: mean over {num_seeds} seeds, band: lowest to highest seed" if num_seeds > 1
            else "one seed")
  how = {"mean": " (the mean action)", "sampled": " (actions sampled)"}.get(eval_actions, "")
  # training.RETURN_KEYS come from the trainer's own evaluation episodes; the other eval/* panels
  # (MI, H(s), LGR, energy distance, mode shares) from the objective's evaluator
  # (``--eval-metrics``), whose episodes sample their actions as Braxlines' evaluation.
  sampled = [k for k in keys if k.startswith("eval/") and k not in training.RETURN_KEYS]
  if not sampled:
    return (f"{spread}. eval/*: the trainer's evaluation episodes after each chunk{how}; loss/*, "
            "disc/*, policy/*, grad_*: means over the chunk's training iterations.")
  return (f"{spread}. eval/episode_reward, _score, _length: the trainer's evaluation episodes "
          f"after each chunk{how}; the other eval/*: the objective's evaluator after each chunk,\n"
          "actions sampled (as Braxlines' evaluation); loss/*, disc/*, policy/*, grad_*: means "
          "over the chunk's training iterations.")


def logged_keys(history: list[dict]) -> list[str]:
  """Every key any row of ``history`` logged, in first-seen order: a statistic first logged when a
  run resumed (e.g. ``grad_clipped``) is drawn from there on."""
  return list(dict.fromkeys(k for row in history for k in row))


def _curve(history: list[dict], key: str) -> np.ndarray:
  """``key``'s values per evaluation and seed, ``[E, seeds]``; NaN (a gap in the curve) where an
  evaluation did not log it."""
  width = next(np.atleast_1d(row[key]).shape[0] for row in history if key in row)
  return np.array([np.atleast_1d(row[key]) if key in row else np.full(width, np.nan)
                   for row in history], np.float64)


def training_curves(history: list[dict], path: str, *, titles: dict[str, str] | None = None,
                    title: str = "", lgr_goals_from: float | None = None,
                    eval_actions: str | None = None) -> list[str]:
  """A grid of curves (mean over seeds, band = min..max) against env steps, each with its y label
  and a caption saying what line and band are; returns the keys. ``titles`` replaces a panel's
  title (default: its key); ``title`` heads the figure. ``lgr_goals_from``: the env steps after
  which the LGR was scored on the paper's goals and before which on blx's old ones (a run resumed
  across session 41, ``runs.lgr_goals_switch``), marked in the LGR panels. ``eval_actions``: how
  the trainer's evaluation episodes acted (the run's ``PPOConfig.eval_actions``), for the
  caption."""
  plt = _pyplot()
  logged = logged_keys(history)
  keys = list(dict.fromkeys(k for p in CURVE_PATTERNS for k in logged if re.match(p, k)))
  cols = min(3, max(1, len(keys)))
  rows = max(1, -(-len(keys) // cols))
  fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.0 * rows), squeeze=False)
  steps = np.array([row["env_steps"] for row in history])
  for ax, key in zip(axes.flat, keys):
    # A multi-agent run's totals are drawn per agent (eval/episode_reward/<agent>), one colour each.
    agents = [k for k in logged
              if key in PER_AGENT and re.match(rf"^{re.escape(key)}/[^/]+$", k)]
    for i, line in enumerate(agents or [key]):
      values = _curve(history, line)  # [E, seeds]
      label = line.rsplit("/", 1)[-1] if agents else None
      ax.plot(steps, values.mean(1), color=f"C{i}", marker="o", ms=2.5, label=label)
      if values.shape[1] > 1:
        ax.fill_between(steps, values.min(1), values.max(1), color=f"C{i}", alpha=0.2)
    if agents:
      ax.legend(fontsize=7, title="agent", title_fontsize=7)
    marked = lgr_goals_from is not None and key.startswith("eval/lgr")
    if marked:
      # the two sides scored other goals: the curve's step there is the goals', not the policy's
      ax.axvline(lgr_goals_from, color="0.3", linestyle="--", linewidth=0.8)
    # A statistic first logged at a resume: the panel spans the whole run, and its title says so.
    first = min(row["env_steps"] for row in history if key in row)
    late = f"\n(logged from {_steps_formatter()(first, None)} on)" if first > steps.min() else ""
    ax.set_title((titles or {}).get(key, key) + (" per agent" if agents else "")
                 + ("\n(left of the dashed line: blx's old goals)" if marked else "") + late,
                 fontsize=9)
    ax.set_xlabel("env steps", fontsize=8)
    margin = 0.05 * (steps.max() - steps.min()) or 0.5
    ax.set_xlim(steps.min() - margin, steps.max() + margin)
    ax.xaxis.set_major_formatter(_steps_formatter())
    ax.set_ylabel(curve_ylabel(key), fontsize=8)
    value_axis(ax, key)
    ax.tick_params(labelsize=7)
  for ax in list(axes.flat)[len(keys):]:
    ax.axis("off")
  seeds = _curve(history, keys[0]).shape[1] if history and keys else 1
  if title:
    fig.suptitle(fit_title(title, fig), fontsize=10)
  caption = band_caption(seeds, keys, eval_actions)
  fig.text(0.5, 0.005, caption, ha="center", va="bottom", fontsize=7, color="0.3")
  # room below the panels for the caption's lines (about 0.12 inch each)
  fig.tight_layout(rect=(0, (0.1 + 0.12 * (1 + caption.count("\n"))) / (3.0 * rows), 1, 1))
  fig.savefig(path, dpi=90)
  plt.close(fig)
  return keys


def skill_colours(num: int):
  """``num`` clearly distinct colours (tab10, then tab20, then evenly spaced hues)."""
  plt = _pyplot()
  if num <= 10:
    return plt.get_cmap("tab10")(np.arange(num))
  if num <= 20:
    return plt.get_cmap("tab20")(np.arange(num))
  return plt.get_cmap("hsv")(np.linspace(0, 1, num, endpoint=False))


def skills(states: np.ndarray, path: str, *, labels: list[str], scale: float,
           title: str = "") -> None:
  """Each skill's cloud of states in the feature space, one colour per skill: ``states
  [L, M, T, D]``, D >= 1 (pairs of dimensions side by side; a 1-D feature against time)."""
  plt = _pyplot()
  num, _, steps, dim = states.shape
  pairs = [(i, i + 1) for i in range(0, dim - 1, 2)] or [(0, None)]
  fig, axes = plt.subplots(1, len(pairs), figsize=(4.6 * len(pairs), 4.2), squeeze=False)
  colours = skill_colours(num)
  for ax, (a, b) in zip(axes.flat, pairs):
    for k in range(num):
      x = states[k, :, :, a]
      y = states[k, :, :, b] if b is not None else x
      x = x if b is not None else np.broadcast_to(np.arange(steps), x.shape)
      ax.scatter(x.ravel(), y.ravel(), color=colours[k], s=4, alpha=0.5, linewidths=0)
      ax.scatter([], [], color=colours[k], s=16, label=f"skill {k}")  # legend marker
    ax.set_xlabel(labels[a] if b is not None else "step")
    ax.set_ylabel(labels[b] if b is not None else labels[a])
    if b is not None:
      ax.set_xlim(-scale * 1.5, scale * 1.5)
      ax.set_ylim(-scale * 1.5, scale * 1.5)
      ax.set_aspect("equal")
  if num <= 12:
    axes.flat[0].legend(fontsize=7, loc="best")
  fig.suptitle(fit_title(f"{title}: states per skill" if title else "states per skill", fig),
               fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=90)
  plt.close(fig)


def root_body(env) -> str:
  """The name of the env's first body: the agent's root (its torso), whose paths ``paths`` draws."""
  return envs.unwrap(env).mj_model.body(1).name


def root_xy(next_state) -> jax.Array:
  """The root body's (``root_body``) xy position in each of a batch of states, ``[N, 2]``: what a
  rollout records for ``paths``."""
  return next_state.data.xpos[:, 1, :2]


def draw_paths(ax, xy: np.ndarray, colours, *, width: float = 1.0, end_size: float = 14,
               start_size: float = 30, legend: bool = False) -> None:
  """One panel of skill paths into ``ax``: ``xy [L, M, T, 2]``, each of the ``M`` episodes of skill
  ``k`` a line in ``colours[k]`` with a dot at its last position, and a circle at every episode's
  first position. ``legend`` labels the skills and the circles."""
  for k in range(xy.shape[0]):
    for m in range(xy.shape[1]):
      ax.plot(xy[k, m, :, 0], xy[k, m, :, 1], color=colours[k], lw=width, alpha=0.75,
              label=f"skill {k}" if legend and m == 0 else None)
    ax.scatter(xy[k, :, -1, 0], xy[k, :, -1, 1], color=colours[k], s=end_size)
  ax.scatter(xy[:, :, 0, 0].ravel(), xy[:, :, 0, 1].ravel(), facecolors="none", edgecolors="k",
             s=start_size, label="start" if legend else None)


def paths(xy: np.ndarray, path: str, *, body: str, title: str = "") -> None:
  """Where each skill takes the agent: the xy position of ``body`` over each episode, ``xy
  [L, M, T, 2]``, one colour per skill, a circle at the start and a dot at the end."""
  plt = _pyplot()
  num = xy.shape[0]
  fig, ax = plt.subplots(figsize=(4.8, 4.4))
  draw_paths(ax, xy, skill_colours(num), legend=num <= 12)
  ax.set_xlabel(f"{body} x position (m)")
  ax.set_ylabel(f"{body} y position (m)")
  ax.set_aspect("equal", adjustable="datalim")
  if num <= 12:
    ax.legend(fontsize=7, loc="best")
  fig.suptitle(fit_title(f"{title}: paths" if title else "paths", fig), fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=90)
  plt.close(fig)


def density(policy_x: np.ndarray, target_x: np.ndarray, path: str, *, labels: list[str],
            scale: float, title: str = "") -> None:
  """Policy (red) vs target (blue) samples in the first two feature dims (or histograms in 1-D)."""
  plt = _pyplot()
  fig, ax = plt.subplots(figsize=(4.6, 4.2))
  if policy_x.shape[1] >= 2:
    ax.scatter(target_x[:, 0], target_x[:, 1], s=6, c="tab:blue", alpha=0.4, label="target")
    ax.scatter(policy_x[:, 0], policy_x[:, 1], s=6, c="tab:red", alpha=0.4, label="policy")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_xlim(-scale, scale)
    ax.set_ylim(-scale, scale)
    ax.set_aspect("equal")
  else:
    bins = np.linspace(-scale, scale, 60)
    ax.hist(target_x[:, 0], bins, color="tab:blue", alpha=0.5, density=True, label="target")
    ax.hist(policy_x[:, 0], bins, color="tab:red", alpha=0.5, density=True, label="policy")
    ax.set_xlabel(labels[0])
  ax.legend(fontsize=8)
  ax.set_title(fit_title(title, fig), fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=90)
  plt.close(fig)


def discriminator(logit_fn, params, path: str, *, dim: int, labels: list[str], scale: float,
                  grid: int = 25, title: str = "") -> None:
  """D(x) = sigmoid(logit) on a ``grid x grid`` grid over [-scale, scale]^2 (red < 0.5 < blue);
  other input dims are 0."""
  plt = _pyplot()
  ticks = np.linspace(-scale, scale, grid)
  if dim >= 2:
    xx, yy = np.meshgrid(ticks, ticks)
    pts = np.zeros((grid * grid, dim), np.float32)
    pts[:, 0], pts[:, 1] = xx.ravel(), yy.ravel()
  else:
    pts = ticks[:, None].astype(np.float32)
  d = np.asarray(jax.nn.sigmoid(jax.vmap(lambda x: logit_fn(params, x))(jnp.asarray(pts))))
  fig, ax = plt.subplots(figsize=(4.8, 4.2))
  if dim >= 2:
    im = ax.imshow(d.reshape(grid, grid), origin="lower", extent=(-scale, scale, -scale, scale),
                   cmap="RdBu", vmin=0, vmax=1)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    fig.colorbar(im, ax=ax, label="D(x) = P(target)")
  else:
    ax.plot(ticks, d)
    ax.set_xlabel(labels[0])
    ax.set_ylabel("D(x)")
  ax.set_title(fit_title(title, fig), fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=90)
  plt.close(fig)


_QUANTITIES = {"root_vel": "velocity", "root_pos": "position", "root_ang": "angular velocity"}


def feature_labels(env, indices) -> list[str]:
  """Readable names of observation indices from the env's layout: ``agent1 velocity x (obs 13)``
  for the root's position, velocity and angular velocity, ``agent1/hip_2 (obs 7)`` and
  ``agent1/hip_2 velocity (obs 21)`` for a joint's angle and velocity, else
  ``agent1/root_quat[0] (obs 1)``."""
  joints = getattr(envs.unwrap(env), "joint_names", {})
  names = {}
  for name, sl in env.obs_layout.items():
    owner, _, piece = name.rpartition("/")
    base, _, suffix = piece.partition("[")
    axes = ([int(a) for a in suffix.rstrip("]").split(",")] if suffix
            else list(range(sl.stop - sl.start)))
    joint_names = joints.get(owner, ())
    for j, i in enumerate(range(sl.start, sl.stop)):
      if base in _QUANTITIES and len(axes) == sl.stop - sl.start and max(axes) < 3:
        names[i] = f"{owner} {_QUANTITIES[base]} {'xyz'[axes[j]]} (obs {i})"
      elif base in ("joint_pos", "joint_vel") and len(joint_names) == sl.stop - sl.start:
        names[i] = f"{joint_names[j]}{' velocity' if base == 'joint_vel' else ''} (obs {i})"
      else:
        names[i] = f"{name}[{j}] (obs {i})"
  return [names.get(int(i), f"obs[{int(i)}]") for i in indices]


def write_all(run, history: list[dict], *, seed_index: int = 0, key_seed: int = 0,
              lgr_goals_from: float | None = None) -> list[str]:
  """Writes every plot of the run directory for one seed; returns the paths written.
  ``lgr_goals_from`` as :func:`training_curves`."""
  out_dir = os.path.join(run.directory, "plots")
  os.makedirs(out_dir, exist_ok=True)
  written = []
  # A run trained off its env's PPO row says so in every title, e.g. "gcrl on halfcheetah; PPO
  # max_grad_norm 5 (default None)", so that an option's figure does not read as the row's: every
  # setting it trained with (``run.config``), also one it took from a default that moved since.
  options = off_row_text(run.spec.env, dataclasses.asdict(run.config))
  trained = f"{run.objective.name} on {run.spec.env}" + (f"; {options}" if options else "")
  if history:
    path = os.path.join(out_dir, "training_curves.png")
    training_curves(history, path, titles=curve_titles(logged_keys(history), run.objective),
                    title=f"{trained}: training curves", lgr_goals_from=lgr_goals_from,
                    eval_actions=run.config.eval_actions)
    written.append(path)
  if run.params is None:
    return written
  params = jax.tree.map(lambda x: x[seed_index], run.params)
  spec = run.objective.spec
  plot = metrics.family_of(run.objective).plot
  length = envs.episode_steps(run.env, "plots")  # policy steps of one of the env's episodes
  key = jax.random.PRNGKey(key_seed)
  name = f"{trained} (seed {run.spec.seeds[seed_index]})"
  if plot == "skills":
    indices = np.asarray(metrics.eval_indices(run.objective))
    latents = metrics.latents_for_evaluation(run.objective, key, 8)
    states, xy = jax.jit(lambda p, z, k: metrics.rollout(
        run.env, run.policy, p, z, k, episodes_per_latent=3,
        record=lambda s, a, n: (n.obs, root_xy(n))))(params, latents, key)
    path = os.path.join(out_dir, "skills.png")
    skills(np.asarray(states[..., indices]), path, labels=feature_labels(run.env, indices),
           scale=spec.obs_scale, title=name)
    written.append(path)
    path = os.path.join(out_dir, "paths.png")
    paths(np.asarray(xy), path, body=root_body(run.env), title=name)
    written.append(path)
  elif plot == "density":
    indices = np.asarray(spec.obs_indices)
    states = jax.jit(lambda p, k: metrics.rollout(
        run.env, run.policy, p, jnp.zeros((1, 0)), k, episodes_per_latent=10,
        conditions_policy=False))(params, key)
    last = max(1, length // 2)
    x = np.asarray(states[0, :, -last:][..., indices]).reshape(-1, len(indices))
    target = np.asarray(spec.target.samples)[:, :len(indices)]
    labels = feature_labels(run.env, indices)
    path = os.path.join(out_dir, "density.png")
    density(x, target, path, labels=labels, scale=spec.obs_scale, title=name)
    written.append(path)
    if getattr(spec, "logit", None) is not None and not getattr(spec, "include_action", False):
      path = os.path.join(out_dir, "discriminator.png")
      discriminator(spec.logit, params.objective, path, dim=len(indices), labels=labels,
                    scale=spec.obs_scale, title=name)
      written.append(path)
  return written
