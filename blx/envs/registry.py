"""Registered environments and ``create``."""

from __future__ import annotations

import copy
import inspect
from typing import Any, Callable, Mapping

from blx.envs import wrappers
from blx.envs.composer import apply_edits
from blx.envs.env import Env
from blx.options import check_params

__all__ = ["create", "list_envs", "register_env", "get_desc", "episode_length", "env_params"]

Desc = Mapping[str, Any]
_ENVS: dict[str, Desc | Callable[..., Desc]] = {}
_EPISODE_LENGTHS: dict[str, int] = {}
DEFAULT_EPISODE_LENGTH = 1000  # Braxlines' episodes
_REGISTERED = object()  # create's default: the env's registered episode length


def register_env(name: str, desc_or_factory: Desc | Callable[..., Desc], *,
                 episode_length: int = DEFAULT_EPISODE_LENGTH) -> None:
  """Registers a desc, or a factory ``(**params) -> desc``, under ``name`` (fails if taken), with
  the episode length ``create`` gives it by default."""
  if not isinstance(name, str) or not name:
    raise ValueError(f"env name must be a non-empty string, got {name!r}")
  if name in _ENVS:
    raise ValueError(f"env {name!r} is already registered")
  if not (callable(desc_or_factory) or isinstance(desc_or_factory, Mapping)):
    raise ValueError(f"register_env({name!r}): expected a desc dict or a factory, got "
                     f"{type(desc_or_factory).__name__}")
  if (not isinstance(episode_length, int) or isinstance(episode_length, bool)
      or not 1 <= episode_length <= wrappers.MAX_STEPS):
    raise ValueError(f"register_env({name!r}): episode_length must be an int in 1..2**31 - 1, got "
                     f"{episode_length!r}")
  _ENVS[name] = desc_or_factory
  _EPISODE_LENGTHS[name] = episode_length


def episode_length(name: str) -> int:
  """The episode length ``create(name)`` gives the env by default."""
  _lookup(name)
  return _EPISODE_LENGTHS[name]


def list_envs() -> list[str]:
  """Names of the registered environments."""
  return sorted(_ENVS)


def env_params(name: str) -> dict[str, Any]:
  """The parameters a registered env accepts, with their defaults."""
  entry = _lookup(name)
  if not callable(entry):
    return {}
  return {n: p.default for n, p in inspect.signature(entry).parameters.items()}


def _lookup(name: str):
  if name not in _ENVS:
    raise ValueError(f"unknown env {name!r}; valid envs are {list_envs()}")
  return _ENVS[name]


def _build(where: str, entry, params: Mapping[str, Any]) -> dict:
  if callable(entry):
    check_params(where, entry, params)
    desc = entry(**params)
  else:
    if params:
      raise ValueError(f"{where}: takes no parameters, got {sorted(params)}")
    desc = entry
  if not isinstance(desc, Mapping):
    raise ValueError(f"{where}: the desc factory returned {type(desc).__name__}, not a dict")
  return copy.deepcopy(dict(desc))


def _merge(base: dict, over: Mapping) -> dict:
  out = dict(base)
  for key, value in over.items():
    out[key] = _merge(out[key], value) if isinstance(value, Mapping) and isinstance(
        out.get(key), dict) else copy.deepcopy(value)
  return out


def get_desc(name: str | None = None, *, desc: Desc | Callable[..., Desc] | None = None,
             edits: Mapping[str, Any] | None = None, **params) -> dict:
  """The final desc ``create`` would build: registered desc, merged with ``desc``, then edits."""
  if name is None and desc is None:
    raise ValueError(f"create: give an env name or a desc; valid envs are {list_envs()}")
  result: dict = {}
  if name is not None:
    result = _build(f"env {name!r}", _lookup(name), params)
    params = {}
  if desc is not None:
    if not (callable(desc) or isinstance(desc, Mapping)):
      raise ValueError(f"create: desc must be a dict or a factory, got {type(desc).__name__}")
    result = _merge(result, _build("desc", desc, params))
  return apply_edits(result, edits)


def create(name: str | None = None, *, desc: Desc | Callable[..., Desc] | None = None,
           edits: Mapping[str, Any] | None = None, episode_length: Any = _REGISTERED,
           action_repeat: int = 1, **params) -> Any:
  """Builds an environment.

  Args:
    name: a registered env (``list_envs()``); its desc is merged under ``desc`` if both are given.
    desc: a desc dict, or a factory called with ``**params``.
    edits: ``{"dotted.path": value}`` applied to the final desc.
    episode_length: steps (of the unrepeated env) before truncation; None for no time limit.
      Default: the env's registered length (``episode_length(name)``: 1000, Braxlines', for every
      body; 50 for the point mass), 1000 for a desc without a name. The env owns its episode:
      the trainer, the evaluations and render run it as given (adding only auto-reset).
    action_repeat: times each action is repeated (env steps counted include the repeats).
    **params: parameters of a registered env factory (e.g. ``num_legs`` of ``pro_ant_run``).

  Returns:
    The ``Env``, wrapped by ``action_repeat`` and ``episode`` (no auto-reset: trainers add it).
  """
  full = get_desc(name, desc=desc, edits=edits, **params)
  if episode_length is _REGISTERED:
    episode_length = _EPISODE_LENGTHS[name] if name is not None else DEFAULT_EPISODE_LENGTH
  env = Env(full, name=name)
  env = wrappers.action_repeat(env, action_repeat)
  if episode_length is not None:
    env = wrappers.episode(env, episode_length)
  return env
