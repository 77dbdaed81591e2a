"""Atomic checkpoints of a training-state pytree.

A checkpoint is one ``.npz`` of the pytree's leaves plus a JSON sidecar. Both are written to temporary
files and moved into place with ``os.replace`` (atomic on POSIX), data first, so a crash while writing
leaves the previous checkpoint whole.
"""

from __future__ import annotations

import json
import os
from typing import Any

import jax
import numpy as np

__all__ = ["save", "restore", "exists", "read_meta"]

DATA, META = "state.npz", "meta.json"


def exists(directory: str) -> bool:
  return os.path.exists(os.path.join(directory, META)) and os.path.exists(
      os.path.join(directory, DATA))


def save(directory: str, tree: Any, meta: dict) -> None:
  """Writes ``tree``'s leaves and ``meta`` (JSON-able) atomically into ``directory``."""
  os.makedirs(directory, exist_ok=True)
  leaves = [np.asarray(x) for x in jax.tree.leaves(jax.device_get(tree))]
  tmp = os.path.join(directory, DATA + ".tmp")
  with open(tmp, "wb") as f:
    np.savez(f, **{f"leaf_{i:05d}": x for i, x in enumerate(leaves)})
    f.flush()
    os.fsync(f.fileno())
  # The meta names the data's leaf count, so a stale pairing is detected on restore.
  meta = {**meta, "num_leaves": len(leaves)}
  os.replace(tmp, os.path.join(directory, DATA))
  tmp_meta = os.path.join(directory, META + ".tmp")
  with open(tmp_meta, "w") as f:
    json.dump(meta, f, indent=1, sort_keys=True)
  os.replace(tmp_meta, os.path.join(directory, META))


def read_meta(directory: str) -> dict:
  with open(os.path.join(directory, META)) as f:
    return json.load(f)


def restore(directory: str, like: Any) -> tuple[Any, dict]:
  """Loads a checkpoint into the structure of ``like`` (a pytree of arrays or shape structs)."""
  meta = read_meta(directory)
  leaves_like, treedef = jax.tree.flatten(like)
  with np.load(os.path.join(directory, DATA)) as data:
    leaves = [data[f"leaf_{i:05d}"] for i in range(len(data.files))]
  if len(leaves) != len(leaves_like) or meta.get("num_leaves") != len(leaves):
    raise ValueError(f"checkpoint in {directory} holds {len(leaves)} arrays but this run's state "
                     f"has {len(leaves_like)}: it was written by a different env, objective or "
                     "config")
  for i, (x, ref) in enumerate(zip(leaves, leaves_like)):
    if x.shape != tuple(ref.shape) or x.dtype != ref.dtype:
      raise ValueError(f"checkpoint in {directory}: array {i} is {x.dtype}{list(x.shape)} but this "
                       f"run expects {ref.dtype}{list(ref.shape)}; it was written by a different "
                       "env, objective or config")
  return jax.tree.unflatten(treedef, [jax.numpy.asarray(x) for x in leaves]), meta
