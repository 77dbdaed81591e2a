"""Carries runs between machines in parts small enough for a transfer limit: a device call here
brings back at most 8 files of 16 MiB (64 MiB together), and a row of #15 outlives the machine it
started on.

    python benchmarks/carry.py pack DIR OUT_DIR [--name NAME] [--part-mb 15] [--keep-env-state]
    python benchmarks/carry.py send STAGE OUT_DIR [--call-mib 64] [--call-files 8]
    python benchmarks/carry.py unpack OUT_DIR/NAME.tar.part_* --into DEST

``pack`` writes the directory tree ``DIR`` (one run, or a sweep's ``--out`` with its points) as one
tar stream cut into ``NAME.tar.part_000``, ``_001``, ... of at most ``--part-mb`` MB each. Every
checkpoint in it goes without the envs' simulator state (``training.drop_env_state``: an Ant or
half-cheetah row's 464 MB become 33 MB), unless ``--keep-env-state``; ``DIR`` itself is not
changed. A run resumed from it starts every env on a new episode.

``send`` is for a pack larger than one call brings back (8 files, 64 MiB together): pack into a
staging directory on the device machine, then let each call end with ``send STAGE $OUT``. It moves
the next parts, in order, that fit beside what ``OUT_DIR`` already holds, and says how many are
left for the next call.

``unpack`` joins the parts in order and extracts them into ``DEST``, so that ``DEST/<DIR's
contents>`` is the tree again and the same training command resumes it. It refuses a missing part,
parts of two packs, and a pack any of whose files ``DEST`` already holds (then it writes nothing).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import shutil
import tarfile
import tempfile

MB = 1_000_000
MIB = 1 << 20
MANIFEST = ".carry-manifest.json"  # the pack's last member: the files it holds, so that a pack
# cut short between two members (a lost last part) is told from a whole one
_PART = re.compile(r"^(?P<name>.+)\.tar\.part_(?P<index>\d{3,})$")


class CarryError(ValueError):
  """Parts that cannot be unpacked, or a tree that cannot be packed, and why."""


class _PartWriter:
  """A file object that writes ``prefix.tar.part_000``, ``_001``, ... of at most ``size`` bytes."""

  def __init__(self, prefix: str, size: int):
    self.prefix, self.size, self.paths, self._file, self._left = prefix, size, [], None, 0

  def write(self, data) -> int:
    view = memoryview(data)
    while view.nbytes:
      if not self._left:
        self._roll()
      n = min(self._left, view.nbytes)
      self._file.write(view[:n])
      self._left -= n
      view = view[n:]
    return len(data)

  def _roll(self) -> None:
    if self._file is not None:
      self._file.close()
    self.paths.append(f"{self.prefix}.tar.part_{len(self.paths):03d}")
    self._file, self._left = open(self.paths[-1], "wb"), self.size

  def close(self) -> None:
    if self._file is not None:
      self._file.close()


class _PartReader:
  """A file object that reads the files ``paths`` one after the other as one stream."""

  def __init__(self, paths: list[str]):
    self._paths, self._file = list(paths), None

  def read(self, size: int = -1) -> bytes:
    out = bytearray()
    while size < 0 or len(out) < size:
      if self._file is None:
        if not self._paths:
          break
        self._file = open(self._paths.pop(0), "rb")
      chunk = self._file.read(-1 if size < 0 else size - len(out))
      if not chunk:
        self._file.close()
        self._file = None
        continue
      out += chunk
    return bytes(out)

  def close(self) -> None:
    if self._file is not None:
      self._file.close()


def _files(tree: str) -> list[str]:
  """Every file under ``tree``, as paths relative to it, sorted."""
  return sorted(os.path.relpath(os.path.join(root, f), tree)
                for root, _, names in os.walk(tree) for f in names)


def checkpoints(directory: str) -> list[str]:
  """The checkpoint directories (holding ``checkpoint.npz``) anywhere under ``directory``."""
  from blx.training import checkpoint
  return sorted(root for root, _, files in os.walk(directory) if checkpoint.FILE in files)


def pack(directory: str, out_dir: str, name: str, *, part_mb: float = 15,
         keep_env_state: bool = False) -> list[str]:
  """Writes the tree ``directory`` as the parts ``out_dir/name.tar.part_NNN`` (each at most
  ``part_mb`` MB), its checkpoints without the envs' state unless ``keep_env_state``; returns the
  parts' paths. ``directory`` is left as it was."""
  from blx import training
  if not os.path.isdir(directory):
    raise CarryError(f"pack: {directory!r} is not a directory")
  if not part_mb > 0:
    raise CarryError(f"pack: --part-mb {part_mb}: give a size above 0 MB")
  if not name or os.sep in name:
    raise CarryError(f"pack: --name {name!r}: give a file name without a path")
  inside = os.path.relpath(os.path.abspath(out_dir), os.path.abspath(directory))
  if inside == "." or not inside.startswith(".."):
    raise CarryError(f"pack: OUT_DIR {out_dir!r} lies inside {directory!r}; the pack would hold "
                     "itself. Choose an OUT_DIR outside the tree")
  os.makedirs(out_dir, exist_ok=True)
  stale = [p for p in os.listdir(out_dir) if p.startswith(f"{name}.tar.part_")]
  if stale:
    raise CarryError(f"pack: {out_dir} already holds parts of {name!r} ({sorted(stale)[0]}, ...); "
                     "remove them or choose another --name, so that no part of two packs mixes")
  with tempfile.TemporaryDirectory() as stage:
    tree = directory
    if not keep_env_state:
      tree = os.path.join(stage, "tree")
      shutil.copytree(directory, tree, ignore=shutil.ignore_patterns("*.tmp"))
      for found in checkpoints(tree):
        training.drop_env_state(found)
    writer = _PartWriter(os.path.join(out_dir, name), int(part_mb * MB))
    try:
      with tarfile.open(fileobj=writer, mode="w|") as tar:
        for entry in sorted(os.listdir(tree)):
          tar.add(os.path.join(tree, entry), arcname=entry)
        manifest = json.dumps({"files": _files(tree)}).encode()
        info = tarfile.TarInfo(MANIFEST)
        info.size = len(manifest)
        tar.addfile(info, io.BytesIO(manifest))
    finally:
      writer.close()
  return writer.paths


def send(stage: str, out_dir: str, *, call_mib: float = 64, call_files: int = 8
         ) -> tuple[list[str], list[str]]:
  """Moves the next parts in ``stage`` (in pack and part order) into ``out_dir``, as many as fit
  beside the files already there: at most ``call_files`` files and ``call_mib`` MiB in all.
  Returns ``(moved, left)``: the moved parts' new paths and the parts still in ``stage``."""
  if not os.path.isdir(stage):
    raise CarryError(f"send: {stage!r} is not a directory")
  parts = sorted((m["name"], int(m["index"]), f) for f in os.listdir(stage)
                 if (m := _PART.match(f)) is not None)
  if not parts:
    raise CarryError(f"send: no parts (NAME.tar.part_NNN) in {stage!r}; pack into it first")
  os.makedirs(out_dir, exist_ok=True)
  there = [os.path.join(out_dir, f) for f in os.listdir(out_dir)]
  files = len(there)
  size = sum(os.path.getsize(f) for f in there if os.path.isfile(f))
  moved = []
  for _, _, part in parts:
    part_size = os.path.getsize(os.path.join(stage, part))
    if files + 1 > call_files or size + part_size > call_mib * MIB:
      break
    os.replace(os.path.join(stage, part), os.path.join(out_dir, part))
    moved.append(os.path.join(out_dir, part))
    files, size = files + 1, size + part_size
  if not moved:
    first = parts[0][2]
    raise CarryError(f"send: {first} ({os.path.getsize(os.path.join(stage, first)) / MIB:.1f}"
                     f" MiB) does not fit beside the {len(there)} files ({size / MIB:.1f} MiB) in "
                     f"{out_dir!r} within {call_files} files and {call_mib:g} MiB; pack with a "
                     "smaller --part-mb or leave OUT_DIR emptier")
  return moved, [os.path.join(stage, f) for _, _, f in parts[len(moved):]]


def _ordered(parts: list[str]) -> list[str]:
  """``parts`` in stream order, after checking they are every part of one stream."""
  if not parts:
    raise CarryError("unpack: no parts given")
  found = {}
  for part in parts:
    match = _PART.match(os.path.basename(part))
    if match is None:
      raise CarryError(f"unpack: {part!r} is not a part (NAME.tar.part_NNN, as pack writes them)")
    found.setdefault(match["name"], {})[int(match["index"])] = part
  if len(found) > 1:
    raise CarryError(f"unpack: parts of {len(found)} packs ({', '.join(sorted(found))}); "
                     "unpack one at a time")
  (indexed,) = found.values()
  missing = sorted(set(range(max(indexed) + 1)) - set(indexed))
  if missing:
    raise CarryError(f"unpack: part {missing[0]:03d} of {len(indexed) + len(missing)} is missing "
                     f"(have {', '.join(f'{i:03d}' for i in sorted(indexed))})")
  return [indexed[i] for i in range(len(indexed))]


def unpack(parts: list[str], dest: str) -> list[str]:
  """Extracts the pack ``parts`` into ``dest``; returns the top-level entries it wrote. All or
  nothing: the pack is extracted beside ``dest``'s files first, and where any of its files exists
  in ``dest`` already, nothing is moved in."""
  ordered = _ordered(parts)
  os.makedirs(dest, exist_ok=True)
  stage = tempfile.mkdtemp(prefix=".carry-", dir=dest)
  reader = _PartReader(ordered)
  try:
    try:
      with tarfile.open(fileobj=reader, mode="r|") as tar:
        for member in tar:
          if hasattr(tarfile, "data_filter"):  # refuses absolute paths, '..' and links out of it
            tar.extract(member, stage, filter="data")
          else:  # pragma: no cover - Python before 3.11.4
            tar.extract(member, stage)
    except getattr(tarfile, "FilterError", ()) as e:
      raise CarryError(f"unpack: the parts {ordered[0]} .. {ordered[-1]} hold an entry that would "
                       f"land outside --into ({e}); they are not a pack that carry.py wrote") from None
    except tarfile.ReadError as e:
      raise CarryError(f"unpack: the parts {ordered[0]} .. {ordered[-1]} are not a whole pack "
                       f"({e}); was a part cut short?") from None
    manifest = os.path.join(stage, MANIFEST)
    if not os.path.exists(manifest):
      raise CarryError(f"unpack: the parts {ordered[0]} .. {ordered[-1]} are not a whole pack (its "
                       "list of files, the last thing packed, is not there); is a last part "
                       "missing or cut short?")
    with open(manifest) as f:
      files = json.load(f)["files"]
    os.remove(manifest)
    got = _files(stage)
    if got != files:
      raise CarryError(f"unpack: the parts hold {len(got)} files where the pack lists "
                       f"{len(files)}; they are not the pack that was written")
    clashes = [f for f in files if os.path.lexists(os.path.join(dest, f))]
    if clashes:
      raise CarryError(f"unpack: {os.path.join(dest, clashes[0])} exists ({len(clashes)} of the "
                       f"pack's {len(files)} files would be overwritten); nothing was extracted. "
                       "Unpack into another --into")
    top = sorted(os.listdir(stage))
    for root, dirs, _ in os.walk(stage):
      for d in dirs:
        os.makedirs(os.path.join(dest, os.path.relpath(os.path.join(root, d), stage)),
                    exist_ok=True)
    for f in files:
      os.replace(os.path.join(stage, f), os.path.join(dest, f))
    return top
  finally:
    reader.close()
    shutil.rmtree(stage, ignore_errors=True)


def main(argv: list[str] | None = None) -> None:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  sub = parser.add_subparsers(dest="command", required=True)
  p = sub.add_parser("pack", help="write DIR as parts into OUT_DIR")
  p.add_argument("directory")
  p.add_argument("out_dir")
  p.add_argument("--name", default=None, help="the parts' name (default: DIR's name)")
  p.add_argument("--part-mb", type=float, default=15, help="the largest part, in MB (default 15)")
  p.add_argument("--keep-env-state", action="store_true",
                 help="keep the envs' simulator state in every checkpoint")
  s = sub.add_parser("send", help="move the next parts that fit one call from STAGE to OUT_DIR")
  s.add_argument("stage")
  s.add_argument("out_dir")
  s.add_argument("--call-mib", type=float, default=64,
                 help="what one call brings back in all, in MiB (default 64)")
  s.add_argument("--call-files", type=int, default=8,
                 help="how many files one call brings back (default 8)")
  u = sub.add_parser("unpack", help="extract parts into --into")
  u.add_argument("parts", nargs="+")
  u.add_argument("--into", required=True, help="the directory the tree lands in")
  args = parser.parse_args(argv)
  try:
    if args.command == "pack":
      name = args.name or os.path.basename(os.path.normpath(args.directory))
      paths = pack(args.directory, args.out_dir, name, part_mb=args.part_mb,
                   keep_env_state=args.keep_env_state)
      print(f"wrote {len(paths)} parts, {sum(os.path.getsize(p) for p in paths) / MB:.1f} MB: "
            f"{paths[0]} .. {paths[-1]}")
    elif args.command == "send":
      moved, left = send(args.stage, args.out_dir, call_mib=args.call_mib,
                         call_files=args.call_files)
      print(f"sent {len(moved)} parts: {os.path.basename(moved[0])} .. "
            f"{os.path.basename(moved[-1])}; "
            + (f"{len(left)} left in {args.stage}: send again in the next call" if left
               else "none left"))
    else:
      print(f"unpacked into {args.into}: {', '.join(unpack(args.parts, args.into))}")
  except CarryError as e:
    parser.exit(2, f"carry.py: {e}\n")


if __name__ == "__main__":
  main()
