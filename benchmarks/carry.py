"""Carries runs between machines, and between sessions, in parts small enough for the transfer
limits: a device call here carries at most 64 MiB there (the working tree included) and brings back
at most 8 files of 16 MiB (64 MiB together); a machine goes back after 30 minutes held, a session
has 30 minutes of device time, and a row of #15 outlives both.

    python benchmarks/carry.py pack DIR OUT_DIR [--name NAME] [--part-mb 16] [--keep-env-state]
    python benchmarks/carry.py send STAGE OUT_DIR [--call-mib 64] [--call-files 8]
    python benchmarks/carry.py unpack OUT_DIR/NAME.tar.part_* --into DEST
    python benchmarks/carry.py fits [PATH ...] [--call-mib 64]
    python benchmarks/carry.py park PARTS ... [--note TEXT] [--replace]
    python benchmarks/carry.py parked
    python benchmarks/carry.py unpark NAME --into DIR
    python benchmarks/carry.py forget NAME
    python benchmarks/carry.py aside
    python benchmarks/carry.py back

``pack`` writes the directory tree ``DIR`` (one run, or a sweep's ``--out`` with its points) as one
tar stream cut into ``NAME.tar.part_000``, ``_001``, ... of at most ``--part-mb`` MB each (default
16, within the 16 MiB a call brings back per file: a 30 MB pack goes in two parts, so two packs and
their logs come back in one call's 8 files). Every checkpoint in it goes without the envs'
simulator state (``training.drop_env_state``: an Ant or half-cheetah row's 464 MB become 33 MB),
unless ``--keep-env-state``, and compact (``checkpoint.save``: lossless, about 15 % smaller
again); ``DIR`` itself is not changed. A run resumed from it starts every env on a new episode.

``send`` is for a pack larger than one call brings back (8 files, 64 MiB together): pack into a
staging directory on the device machine, then let each call end with ``send STAGE $OUT``. It moves
the next parts, in order, that fit beside what ``OUT_DIR`` already holds, and says how many are
left for the next call.

``unpack`` joins the parts in order and extracts them into ``DEST``, so that ``DEST/<DIR's
contents>`` is the tree again and the same training command resumes it. It refuses a missing part,
parts of two packs, and a pack any of whose files ``DEST`` already holds (then it writes nothing).

``fits`` says whether a device call that carries the ``PATH``s (ignored by git, as ``run``'s
``carry`` takes them) travels: what travels is the working tree's tracked files and the untracked
ones git does not ignore, plus the carried paths, at most ``--call-mib`` MiB together. It exits
with 1 where they do not fit, and names the margin either way.

Between sessions nothing survives but the repository's history, so ``park`` keeps a pack there:
it commits the parts under ``benchmarks/parked/NAME/``, then removes them from the tree in a second
commit that records the first in ``benchmarks/parked.json`` (with each part's size, SHA-256 and
git object, by which ``unpark`` reads it).
The parts then cost the repository's history their size, and no later call's carry anything.
``park`` refuses a pack that is not whole (a missing or cut part), a name already parked, and a
repository with staged changes (they would go into its commit). A run parked, resumed and stopped
again is parked anew with ``--replace``: its newer pack takes the name's entry in the ledger, which
keeps the commits of the packs it replaced (``replaces``, newest first), all still in the history.
``unpark NAME --into DIR`` writes the parts back from the history, checking every one against its
recorded SHA-256, ready to carry; ``parked`` lists what is parked, and ``forget NAME`` drops a
finished pack from the ledger (its parts stay in the history; commit the ledger with the run's
results).

The working tree itself is most of a call's 64 MiB: the committed results (``benchmarks/paper``,
``benchmarks/multiagent``: figures, metrics and finished checkpoints, about 44 MiB by session 87)
travel with every call, though nothing on the device reads them. With them the wheels (24 MiB) alone
are more than a call carries, and no pack (28 MiB) fits. ``aside`` moves those folders (``ASIDE``)
out of the tree, into ``.git/blx-aside`` (which does not travel), for the calls; ``back`` returns
them. A first call then carries the wheels and a pack (about 53 MiB), a later one two packs. Nothing
is lost either way: ``aside`` refuses where ``.git/blx-aside`` holds them already, ``back`` where
the tree holds them again (say, after a checkout), and both leave the other side as it was. While
they are aside, git sees them deleted: commit nothing with ``-a`` until ``back``.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import io
import json
import os
import re
import shutil
import subprocess
import tarfile
import tempfile
from typing import NamedTuple

MB = 1_000_000
MIB = 1 << 20
PARKED_DIR = os.path.join("benchmarks", "parked")  # where park commits a pack's parts, in a repo
LEDGER = os.path.join("benchmarks", "parked.json")  # which commit holds each parked pack
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


def pack(directory: str, out_dir: str, name: str, *, part_mb: float = 16,
         keep_env_state: bool = False) -> list[str]:
  """Writes the tree ``directory`` as the parts ``out_dir/name.tar.part_NNN`` (each at most
  ``part_mb`` MB), its checkpoints compact and without the envs' state unless ``keep_env_state``;
  returns the parts' paths. ``directory`` is left as it was."""
  from blx import training
  from blx.training import checkpoint
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
    tree = os.path.join(stage, "tree")
    shutil.copytree(directory, tree, ignore=shutil.ignore_patterns("*.tmp"))
    for found in checkpoints(tree):
      if keep_env_state:
        checkpoint.rewrite(found, compact=True)
      else:
        training.drop_env_state(found, compact=True)
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


def _extract(ordered: list[str], stage: str) -> list[str]:
  """Extracts the pack whose parts are ``ordered`` into the empty directory ``stage`` and checks it
  against its list of files; returns that list (the list itself is not left in ``stage``)."""
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
      raise CarryError(f"the parts {ordered[0]} .. {ordered[-1]} hold an entry that would land "
                       f"outside the folder it is extracted into ({e}); they are not a pack that "
                       "carry.py wrote") from None
    except tarfile.ReadError as e:
      raise CarryError(f"the parts {ordered[0]} .. {ordered[-1]} are not a whole pack ({e}); was "
                       "a part cut short?") from None
  finally:
    reader.close()
  manifest = os.path.join(stage, MANIFEST)
  if not os.path.exists(manifest):
    raise CarryError(f"the parts {ordered[0]} .. {ordered[-1]} are not a whole pack (its list of "
                     "files, the last thing packed, is not there); is a last part missing or cut "
                     "short?")
  with open(manifest) as f:
    files = json.load(f)["files"]
  os.remove(manifest)
  got = _files(stage)
  if got != files:
    raise CarryError(f"the parts hold {len(got)} files where the pack lists {len(files)}; they are "
                     "not the pack that was written")
  return files


def unpack(parts: list[str], dest: str) -> list[str]:
  """Extracts the pack ``parts`` into ``dest``; returns the top-level entries it wrote. All or
  nothing: the pack is extracted beside ``dest``'s files first, and where any of its files exists
  in ``dest`` already, nothing is moved in."""
  ordered = _ordered(parts)
  os.makedirs(dest, exist_ok=True)
  stage = tempfile.mkdtemp(prefix=".carry-", dir=dest)
  try:
    try:
      files = _extract(ordered, stage)
    except CarryError as e:
      raise CarryError(f"unpack: {e}") from None
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
    shutil.rmtree(stage, ignore_errors=True)


# --------------------------------------------------------------------------------------------------
# What a call carries, and packs kept between sessions in the repository's history.

def _git(repo: str, *args: str, binary: bool = False):
  """``git -C repo args``' standard output (text, stripped, or bytes); a CarryError naming the
  command and git's message where it fails."""
  try:
    done = subprocess.run(["git", "-C", repo, *args], capture_output=True, check=False)
  except FileNotFoundError:
    raise CarryError("git is not installed; this command needs it") from None
  if done.returncode:
    raise CarryError(f"git {' '.join(args)} (in {repo}) failed: "
                     f"{done.stderr.decode(errors='replace').strip()}")
  return done.stdout if binary else done.stdout.decode().strip()


def _root(repo: str) -> str:
  """The top of the git working tree holding ``repo``."""
  if not os.path.isdir(repo):
    raise CarryError(f"{repo!r} is not a directory")
  try:
    return _git(repo, "rev-parse", "--show-toplevel")
  except CarryError:
    raise CarryError(f"{os.path.abspath(repo)!r} is not inside a git working tree") from None


def _size(path: str) -> int:
  """Bytes of the file ``path``, or of every file under the directory ``path`` (links as links)."""
  if not os.path.isdir(path) or os.path.islink(path):
    return os.lstat(path).st_size
  return sum(os.lstat(os.path.join(root, f)).st_size
             for root, _, names in os.walk(path) for f in names)


class Fit(NamedTuple):
  """What one device call would carry, in bytes."""
  tree: int                       # tracked files and untracked ones git does not ignore
  tree_files: int
  carried: list[tuple[str, int]]  # (path as given, bytes) of every carried path
  limit: int

  @property
  def total(self) -> int:
    return self.tree + sum(size for _, size in self.carried)

  @property
  def fits(self) -> bool:
    return self.total <= self.limit


def fits(paths: list[str], *, repo: str = ".", call_mib: float = 64) -> Fit:
  """What a device call from ``repo``'s working tree that carries ``paths`` (ignored by git) would
  carry, against ``call_mib`` MiB. A checkout's own ``shared/`` travels too and is counted."""
  root = _root(repo)
  listed = _git(root, "ls-files", "-z", "--cached", "--others", "--exclude-standard")
  files = [os.path.join(root, f) for f in listed.split("\0") if f]
  files = [f for f in files if os.path.lexists(f)]  # a tracked file deleted in the tree stays here
  if os.path.isdir(os.path.join(root, "shared")):
    seen = set(files)
    files += [os.path.join(r, f) for r, _, names in os.walk(os.path.join(root, "shared"))
              for f in names if os.path.join(r, f) not in seen]
  carried = []
  for path in paths:
    if not os.path.lexists(path):
      raise CarryError(f"fits: {path!r} does not exist")
    inside = os.path.relpath(os.path.abspath(path), root)
    if inside.startswith(".."):
      raise CarryError(f"fits: {path!r} lies outside the working tree {root}; a call carries only "
                       "paths inside it (copy it into an ignored folder of the tree)")
    ignored = subprocess.run(["git", "-C", root, "check-ignore", "-q", "--", inside],
                             capture_output=True).returncode == 0
    if not ignored:
      raise CarryError(f"fits: {path!r} is not ignored by git, so it travels with the tree "
                       "already; a call's carry names ignored paths (add it to .git/info/exclude)")
    carried.append((path, _size(path)))
  return Fit(sum(os.lstat(f).st_size for f in files), len(files), carried, int(call_mib * MIB))


def _parts(n: int) -> str:
  return f"{n} part" + ("" if n == 1 else "s")


def _sha256(data: bytes) -> str:
  return hashlib.sha256(data).hexdigest()


def read_ledger(repo: str = ".") -> dict:
  """``benchmarks/parked.json`` of ``repo``: ``{name: {commit, path, parts: [{file, bytes, sha256,
  blob}], note, parked}}``; empty where nothing was ever parked. ``blob`` is the part's git object,
  read by ``unpark`` (it stays the same where commits are rewritten); ``commit`` says where it
  was committed."""
  path = os.path.join(_root(repo), LEDGER)
  if not os.path.exists(path):
    return {}
  with open(path) as f:
    return json.load(f)


def _write_ledger(root: str, ledger: dict) -> None:
  path = os.path.join(root, LEDGER)
  os.makedirs(os.path.dirname(path), exist_ok=True)
  with open(path + ".tmp", "w") as f:
    json.dump(ledger, f, indent=2, sort_keys=True)
    f.write("\n")
  os.replace(path + ".tmp", path)


def park(parts: list[str], *, repo: str = ".", note: str = "", replace: bool = False) -> str:
  """Keeps the whole pack ``parts`` in ``repo``'s history (see the module's docstring); returns the
  commit that holds the parts. Makes two commits; the tree ends as it began, but for the ledger.
  With ``replace``, a pack of the name parked already gives way to this one (a run parked again
  after a resume); without, it is refused."""
  ordered = _ordered(parts)
  name = _PART.match(os.path.basename(ordered[0]))["name"]
  with tempfile.TemporaryDirectory() as check:
    try:
      _extract(ordered, check)
    except CarryError as e:
      raise CarryError(f"park: {e}; a pack that is not whole is not parked") from None
  root = _root(repo)
  ledger = read_ledger(root)
  if name in ledger and not replace:
    raise CarryError(f"park: a pack named {name!r} is parked already (commit "
                     f"{ledger[name]['commit'][:10]}); a newer pack of the same run: park "
                     "--replace; another run: `carry.py pack --name` another name")
  if name not in ledger and replace:
    raise CarryError(f"park: --replace, but no pack named {name!r} is parked; parked: "
                     f"{', '.join(sorted(ledger)) or 'none'}")
  staged = _git(root, "diff", "--cached", "--name-only")
  if staged:
    raise CarryError(f"park: {root} has staged changes ({staged.splitlines()[0]}, ...); commit or "
                     "unstage them first, since park commits")
  rel = f"{PARKED_DIR}/{name}".replace(os.sep, "/")
  where = os.path.join(root, rel)
  if os.path.lexists(where):
    raise CarryError(f"park: {where} exists already; move it away first")
  os.makedirs(where)
  entries = []
  for part in ordered:
    with open(part, "rb") as f:
      data = f.read()
    with open(os.path.join(where, os.path.basename(part)), "wb") as f:
      f.write(data)
    entries.append(dict(file=os.path.basename(part), bytes=len(data), sha256=_sha256(data)))
  size = sum(e["bytes"] for e in entries)
  _git(root, "add", "-f", "--", rel)
  _git(root, "commit", "-q", "-m", f"carry.py park {name}: {_parts(len(entries))}, "
       f"{size / MB:.1f} MB, kept in the history (the next commit takes them out of the tree)")
  commit = _git(root, "rev-parse", "HEAD")
  for entry in entries:  # the parts' contents by name, which no rewrite of commits changes
    entry["blob"] = _git(root, "rev-parse", f"{commit}:{rel}/{entry['file']}")
  _git(root, "rm", "-r", "-q", "--", rel)
  older = ledger.get(name)
  ledger[name] = dict(commit=commit, path=rel, parts=entries, note=note,
                      parked=datetime.date.today().isoformat())
  if older:
    ledger[name]["replaces"] = [older["commit"], *older.get("replaces", [])]
  _write_ledger(root, ledger)
  _git(root, "add", "--", LEDGER)
  _git(root, "commit", "-q", "-m", f"carry.py park {name}: the parts leave the tree; {LEDGER} "
       f"names {commit[:10]}, which holds them")
  return commit


def _parked(verb: str, name: str, repo: str) -> tuple[str, dict, dict]:
  """``repo``'s root, its ledger and the entry of the parked pack ``name``; a CarryError from
  ``verb`` naming what is parked where ``name`` is not."""
  root = _root(repo)
  ledger = read_ledger(root)
  if name not in ledger:
    raise CarryError(f"{verb}: no pack named {name!r} is parked; parked: "
                     f"{', '.join(sorted(ledger)) or 'none'}")
  return root, ledger, ledger[name]


def unpark(name: str, into: str, *, repo: str = ".") -> list[str]:
  """Writes the parts of the parked pack ``name`` into ``into`` from the history (each read by its
  git object and checked against its recorded size and SHA-256); returns their paths. All or
  nothing."""
  root, _, entry = _parked("unpark", name, repo)
  targets = [os.path.join(into, p["file"]) for p in entry["parts"]]
  there = [t for t in targets if os.path.lexists(t)]
  if there:
    raise CarryError(f"unpark: {there[0]} exists; nothing was written. Unpark into another --into")
  blobs = []
  for part in entry["parts"]:
    try:
      data = _git(root, "cat-file", "blob", part["blob"], binary=True)
    except CarryError as e:
      raise CarryError(f"unpark: {part['file']} (blob {part['blob'][:10]} of commit "
                       f"{entry['commit'][:10]}) cannot be read ({e}); where the clone is shallow, "
                       "`git fetch --unshallow` brings the history") from None
    if len(data) != part["bytes"] or _sha256(data) != part["sha256"]:
      raise CarryError(f"unpark: {part['file']} at {entry['commit'][:10]} is not the part that was "
                       "parked (its size or SHA-256 differs); nothing was written")
    blobs.append(data)
  os.makedirs(into, exist_ok=True)
  for target, data in zip(targets, blobs):
    with open(target + ".tmp", "wb") as f:
      f.write(data)
    os.replace(target + ".tmp", target)
  return targets


def forget(name: str, *, repo: str = ".") -> dict:
  """Drops ``name`` from the ledger (not committed; its parts stay in the history); returns its
  entry."""
  root, ledger, entry = _parked("forget", name, repo)
  del ledger[name]
  _write_ledger(root, ledger)
  return entry


ASIDE = ("benchmarks/paper", "benchmarks/multiagent")  # committed results no device call reads


def _aside_dir(root: str) -> str:
  return os.path.join(root, _git(root, "rev-parse", "--git-dir"), "blx-aside")


def aside(*, repo: str = ".") -> list[str]:
  """Moves ``ASIDE``'s folders out of ``repo``'s working tree into ``.git/blx-aside`` (see the
  module's docstring); returns those moved. Refuses, moving nothing, where ``.git/blx-aside``
  holds any of them already (an earlier ``aside`` not brought ``back``)."""
  root = _root(repo)
  store = _aside_dir(root)
  held = [rel for rel in ASIDE if os.path.lexists(os.path.join(store, rel))]
  if held:
    raise CarryError(f"aside: {os.path.join(store, held[0])} exists already (set aside before and "
                     "not brought back); run `carry.py back` first. Nothing was moved")
  moved = [rel for rel in ASIDE if os.path.lexists(os.path.join(root, rel))]
  for rel in moved:
    os.makedirs(os.path.dirname(os.path.join(store, rel)), exist_ok=True)
    os.rename(os.path.join(root, rel), os.path.join(store, rel))
  return moved


def back(*, repo: str = ".") -> list[str]:
  """Returns what ``aside`` moved into ``.git/blx-aside`` to ``repo``'s working tree; returns those
  moved. Refuses, moving nothing, where the tree holds any of them again."""
  root = _root(repo)
  store = _aside_dir(root)
  held = [rel for rel in ASIDE if os.path.lexists(os.path.join(store, rel))]
  again = [rel for rel in held if os.path.lexists(os.path.join(root, rel))]
  if again:
    raise CarryError(f"back: {os.path.join(root, again[0])} exists in the tree again (a checkout "
                     f"since `aside`?), beside {os.path.join(store, again[0])}: compare them and "
                     "remove one. Nothing was moved")
  for rel in held:
    os.rename(os.path.join(store, rel), os.path.join(root, rel))
  shutil.rmtree(store, ignore_errors=True)
  return held


def main(argv: list[str] | None = None) -> None:
  parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
  sub = parser.add_subparsers(dest="command", required=True)
  p = sub.add_parser("pack", help="write DIR as parts into OUT_DIR")
  p.add_argument("directory")
  p.add_argument("out_dir")
  p.add_argument("--name", default=None, help="the parts' name (default: DIR's name)")
  p.add_argument("--part-mb", type=float, default=16, help="the largest part, in MB (default 16)")
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
  f = sub.add_parser("fits", help="whether a call carrying PATHs (ignored by git) travels")
  f.add_argument("paths", nargs="*")
  f.add_argument("--call-mib", type=float, default=64,
                 help="what one call carries, the working tree included, in MiB (default 64)")
  f.add_argument("--repo", default=".", help="the checkout the call is made from (default .)")
  k = sub.add_parser("park", help="keep a whole pack in the repository's history")
  k.add_argument("parts", nargs="+")
  k.add_argument("--note", default="", help="what the pack is and how to resume it")
  k.add_argument("--replace", action="store_true",
                 help="a pack of this name is parked already: this newer one of the same run "
                 "takes its place (the ledger keeps the older commits under `replaces`)")
  k.add_argument("--repo", default=".")
  sub.add_parser("parked", help="list the parked packs").add_argument("--repo", default=".")
  n = sub.add_parser("unpark", help="write a parked pack's parts into --into")
  n.add_argument("name")
  n.add_argument("--into", required=True, help="the directory the parts land in")
  n.add_argument("--repo", default=".")
  g = sub.add_parser("forget", help="drop a parked pack from the ledger (its run is done)")
  g.add_argument("name")
  g.add_argument("--repo", default=".")
  sub.add_parser("aside", help="move the committed results out of the tree for device calls"
                 ).add_argument("--repo", default=".")
  sub.add_parser("back", help="return what `aside` moved").add_argument("--repo", default=".")
  args = parser.parse_args(argv)
  try:
    if args.command == "pack":
      name = args.name or os.path.basename(os.path.normpath(args.directory))
      paths = pack(args.directory, args.out_dir, name, part_mb=args.part_mb,
                   keep_env_state=args.keep_env_state)
      print(f"wrote {_parts(len(paths))}, {sum(os.path.getsize(p) for p in paths) / MB:.1f} MB: "
            f"{paths[0]} .. {paths[-1]}")
    elif args.command == "send":
      moved, left = send(args.stage, args.out_dir, call_mib=args.call_mib,
                         call_files=args.call_files)
      print(f"sent {_parts(len(moved))}: {os.path.basename(moved[0])} .. "
            f"{os.path.basename(moved[-1])}; "
            + (f"{len(left)} left in {args.stage}: send again in the next call" if left
               else "none left"))
    elif args.command == "unpack":
      print(f"unpacked into {args.into}: {', '.join(unpack(args.parts, args.into))}")
    elif args.command == "fits":
      fit = fits(args.paths, repo=args.repo, call_mib=args.call_mib)
      print(f"the working tree: {fit.tree / MIB:.1f} MiB ({fit.tree_files} files)")
      for path, size in fit.carried:
        print(f"{path}: {size / MIB:.1f} MiB")
      margin = (fit.limit - fit.total) / MIB
      print(f"together {fit.total / MIB:.1f} MiB: "
            + (f"fits the {args.call_mib:g} MiB a call carries, {margin:.1f} MiB to spare"
               if fit.fits else f"over the {args.call_mib:g} MiB a call carries by {-margin:.1f} "
               "MiB"))
      root = _root(args.repo)
      spare = sum(_size(os.path.join(root, rel)) for rel in ASIDE
                  if os.path.lexists(os.path.join(root, rel)))
      if not fit.fits and spare:
        left = (fit.total - spare) / MIB
        print(f"with `carry.py aside` ({', '.join(ASIDE)} out of the tree, {spare / MIB:.1f} MiB) "
              f"{left:.1f} MiB: " + ("fits" if left * MIB <= fit.limit else "still over"))
      if not fit.fits:
        parser.exit(1)
    elif args.command == "park":
      commit = park(args.parts, repo=args.repo, note=args.note, replace=args.replace)
      print(f"parked in commit {commit[:10]} (two commits made); `carry.py unpark NAME --into DIR` "
            "brings the parts back")
    elif args.command == "parked":
      ledger = read_ledger(args.repo)
      for name, entry in sorted(ledger.items()):
        size = sum(p["bytes"] for p in entry["parts"])
        print(f"{name}: {_parts(len(entry['parts']))}, {size / MB:.1f} MB, commit "
              f"{entry['commit'][:10]}, parked {entry['parked']}"
              + (f" (replaces {len(entry['replaces'])} older)" if entry.get("replaces") else "")
              + (f": {entry['note']}" if entry["note"] else ""))
      if not ledger:
        print("nothing is parked")
    elif args.command == "unpark":
      paths = unpark(args.name, args.into, repo=args.repo)
      print(f"unparked {_parts(len(paths))} into {args.into}: {os.path.basename(paths[0])} .. "
            f"{os.path.basename(paths[-1])}")
    elif args.command == "aside":
      moved = aside(repo=args.repo)
      fit = fits([], repo=args.repo)
      print(f"set aside in .git/blx-aside: {', '.join(moved) or 'nothing (none in the tree)'}; "
            f"the working tree travels as {fit.tree / MIB:.1f} MiB. Git sees them deleted until "
            "`carry.py back`: commit nothing with -a before")
    elif args.command == "back":
      moved = back(repo=args.repo)
      print(f"brought back: {', '.join(moved)}" if moved else "nothing was set aside")
    else:
      entry = forget(args.name, repo=args.repo)
      print(f"forgot {args.name} (commit {entry['commit'][:10]} keeps its parts); commit "
            f"{LEDGER}")
  except CarryError as e:
    parser.exit(2, f"carry.py: {e}\n")


if __name__ == "__main__":
  main()
