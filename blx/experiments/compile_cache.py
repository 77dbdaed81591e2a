"""JAX's persistent compilation cache for the ``blx`` command, on by default.

A ``blx`` command spends most of its start compiling (MJX physics, the training chunk, the
evaluator). With the cache, a second run of the same program (same env, objective, config and
batch shapes, jax version and device) loads the compiled programs from disk instead.

* Default directory: ``$XDG_CACHE_HOME/blx/jax`` (``~/.cache/blx/jax`` when unset).
* ``BLX_COMPILATION_CACHE=DIR`` puts it elsewhere; ``BLX_COMPILATION_CACHE=off`` turns it off.
* A cache directory JAX was already given (``JAX_COMPILATION_CACHE_DIR`` or
  ``jax.config.update("jax_compilation_cache_dir", ...)``) is left as it is.

Only programs that take at least a second to compile are stored (JAX's default). The entries are
keyed by the program and the jax/XLA versions, so a stale entry is never used; delete the directory
to reclaim the space.
"""

from __future__ import annotations

import os
import sys

__all__ = ["ENV_VAR", "default_directory", "enable"]

ENV_VAR = "BLX_COMPILATION_CACHE"
_OFF = ("0", "off", "false", "no", "none", "disable", "disabled")


def default_directory() -> str:
  base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
  return os.path.join(base, "blx", "jax")


def enable(directory: str | None = None) -> str | None:
  """Turns the cache on in ``directory`` (default: ``$BLX_COMPILATION_CACHE``, else
  :func:`default_directory`) and returns it; ``None`` when it is off.

  Call it before the first compilation. A directory that cannot be created leaves the cache off
  with a one-line warning, never an error: the cache only saves time.
  """
  import jax

  already = getattr(jax.config, "jax_compilation_cache_dir", None)
  if already:
    return already
  setting = os.environ.get(ENV_VAR, "").strip()
  if directory is None:
    if setting.lower() in _OFF:
      return None
    directory = setting or default_directory()
  directory = os.path.abspath(os.path.expanduser(directory))
  try:
    os.makedirs(directory, exist_ok=True)
    if not os.access(directory, os.W_OK):
      raise PermissionError(f"not writable: {directory}")
  except OSError as e:
    print(f"[blx] compilation cache off: cannot use {directory} ({e}); set {ENV_VAR}=DIR to "
          f"choose another or {ENV_VAR}=off", file=sys.stderr)
    return None
  jax.config.update("jax_compilation_cache_dir", directory)
  return directory
