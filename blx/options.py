"""The one check of named options in blx: every place that takes keyword options by name (env and
component parameters, desc keys, reward keys, objective options, PPO config keys) rejects unknown
names through :func:`check_names`, so every such error reads the same way."""

from __future__ import annotations

import inspect
import math
from typing import Any, Callable, Iterable, Mapping

__all__ = ["check_names", "check_params", "keyword_names", "accepts_any_keyword", "finite_number"]


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


def check_params(where: str, fn: Callable, params: Mapping[str, Any]) -> None:
  """Rejects parameters ``fn`` does not take (unless it takes ``**kwargs``) and values whose type
  differs from the parameter's default: a float default takes ints and floats, a tuple default
  tuples and lists, an int default ints only (booleans are never numbers)."""
  signature = inspect.signature(fn)
  if not accepts_any_keyword(fn):
    check_names(where, params, keyword_names(fn), "parameter")
  for key, value in params.items():
    if key not in signature.parameters:
      continue
    default = signature.parameters[key].default
    if default is inspect.Parameter.empty or default is None:
      continue
    expected = (int, float) if isinstance(default, float) else type(default)
    if isinstance(default, (tuple, list)):
      expected = (tuple, list)
    if isinstance(default, float) and isinstance(value, (tuple, list)):
      continue  # e.g. singleton size=(radius, length); the factory checks the form
    if isinstance(value, bool) and not isinstance(default, bool):
      raise ValueError(f"{where}: parameter {key!r} must be {type(default).__name__}, "
                       f"got {value!r}")
    if not isinstance(value, expected):
      raise ValueError(
          f"{where}: parameter {key!r} must be {type(default).__name__}, got {value!r} "
          f"({type(value).__name__})")
    numbers = value if isinstance(value, (tuple, list)) else (value,)
    if any(isinstance(v, float) and not math.isfinite(v) for v in numbers):
      raise ValueError(f"{where}: parameter {key!r} must be finite, got {value!r}")


def finite_number(where: str, value: Any) -> float:
  """``value`` as a float when it is a finite int or float (not a bool), else ``ValueError``
  naming ``where``."""
  if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
    raise ValueError(f"{where}: must be a finite number, got {value!r}")
  return float(value)
