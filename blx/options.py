"""The one check of named options in blx: every place that takes keyword options by name (env and
component parameters, desc keys, reward keys, objective options, PPO config keys) rejects unknown
names through :func:`check_names`, so every such error reads the same way."""

from __future__ import annotations

import inspect
from typing import Any, Callable, Iterable

__all__ = ["check_names", "keyword_names", "accepts_any_keyword"]


def keyword_names(fn: Callable, *, keyword_only: bool = False) -> list[str]:
  """The names ``fn`` accepts as keywords (``**kwargs`` excluded); only keyword-only ones when
  ``keyword_only``."""
  kinds = ((inspect.Parameter.KEYWORD_ONLY,) if keyword_only else
           (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD))
  return [n for n, p in inspect.signature(fn).parameters.items() if p.kind in kinds]


def accepts_any_keyword(fn: Callable) -> bool:
  """Whether ``fn`` takes ``**kwargs``."""
  return any(p.kind is p.VAR_KEYWORD for p in inspect.signature(fn).parameters.values())


def check_names(where: str, given: Iterable[Any], valid: Iterable[str], what: str = "key",
                extra_valid: Iterable[str] = ()) -> None:
  """Raises ``ValueError("<where>: unknown <what>(s) [...]; valid <what>s are [...]")`` when
  ``given`` holds a name outside ``valid`` (``extra_valid`` are also accepted and listed)."""
  valid = list(valid) + [v for v in extra_valid if v not in valid]
  unknown = sorted((g for g in given if g not in valid), key=str)
  if unknown:
    raise ValueError(f"{where}: unknown {what}(s) {unknown}; valid {what}s are "
                     f"{sorted(valid) if valid else 'none'}")
