#!/usr/bin/env bash
# The body of one device call of a run that outlives calls, machines and sessions.
#
#   bash benchmarks/device_call.sh NAME RUN_DIR SECONDS COMMAND [ARG ...]
#
# Run from the repository's root on the device machine; $OUT is the call's output folder.
# 1. Wheels: where .whl-train/ (or else .whl/) was carried and /tmp/site is not yet filled, they
#    are installed there once per machine; /tmp/site and the tree go on PYTHONPATH.
# 2. Resume: where RUN_DIR does not exist and .carry/NAME/ holds NAME's parts (NAME.tar.part_*,
#    as `carry.py unpark NAME --into .carry/NAME` writes them, carried with this call or an
#    earlier one on the same machine: a call carrying .carry/B leaves .carry/A there), they are
#    unpacked into RUN_DIR. A RUN_DIR left by an earlier call on the same machine is kept as it
#    is, and wins. $CARRY_ROOT moves .carry. With RESUME=1 a call that finds neither refuses
#    (status 3) rather than start the run anew: give it for a parked run. One pack's parts may
#    come in different calls to the same machine: where the wheels and two packs are more than a
#    call carries, a call of seconds carries .whl-train and each pack's first part
#    (.carry/NAME/NAME.tar.part_000), and the next each pack's second part, so that both arms
#    start in that call.
# 3. Train: COMMAND runs (it must train RUN_DIR, resuming it where it exists: the studies,
#    ablations.py, paper_tables.py and `blx sweep`, resume by themselves; `blx train` needs
#    `--resume RUN_DIR` from the second call on), logged to $OUT/NAME.log, and is interrupted
#    (SIGINT, then killed 30 s later) SECONDS after it starts: the run keeps its last whole
#    checkpoint, written after every evaluation. Leave the call's 600 s room for that and the
#    pack: SECONDS 540 at most. With BLX_CHECKPOINT_SEGMENTS=N in the call's environment (e.g.
#    `BLX_CHECKPOINT_SEGMENTS=4 bash benchmarks/device_call.sh ...`) the run also checkpoints N - 1
#    times within each chunk, so the call loses at most a segment, not most of a chunk (the
#    legs rows': a chunk of 277 s, one in a call of 540 s without; the run is the same. Measured,
#    session 57: with N=4 a chunk still takes 277 s, and a call of 540 s keeps 1.75 chunks).
# 4. Carry back: RUN_DIR, where it holds a checkpoint, is packed (`carry.py pack`: checkpoints
#    compact, without the envs' state) and its parts go to $OUT beside the log, so that a machine
#    lost after the call loses nothing (a new run stopped before its first checkpoint is not
#    packed: nothing in it resumes); calls side by side send their parts in turn
#    ($STAGE_ROOT/blx-send.lock), each counting what the other left in $OUT; `carry.py park
#    FILES_AT/NAME.tar.part_*` on the CPU machine keeps the last call's pack for the next session.
#    A run the call left as it found it (a finished run, whose command only reports; a command
#    that failed before its first chunk ended, which changed only the run's provenance.json) is
#    not packed again: its last pack, carried here or sent by an earlier call, holds it already,
#    and sending it anew would take the room of another arm's parts, or of a later call's on the
#    same run; only parts an earlier call left staged are sent.
#    Parts that do not fit the call's return (8 files, 64 MiB) stay in /tmp/stage-NAME, and
#    `send` says so: a call of `python3 benchmarks/carry.py send /tmp/stage-NAME $OUT` alone
#    brings them, before the next call packs the run anew. Every file under $OUT counts, the
#    call's own too: two arms' logs and packs take six of the eight, so a call that also writes
#    results of its own (an evaluation's JSON and stderr) puts them in one file (session 59: six
#    such files left no room for either pack).
#
# Two rows side by side (one per GPU, CUDA_VISIBLE_DEVICES=0 and 1): start both in the background
# and `wait` for both, e.g. `A & B & wait`. The device machine ends the call's whole process
# session when the call's command line returns, so an arm left running behind a foreground arm
# that returns early (a RESUME=1 refusal, a bad argument) is killed before it packs, and what it
# trained since its last pack is lost. Never stop an arm with `pkill -f PATTERN` from the call's
# command line either: the pattern matches that command line itself and kills the call.
#
# The exit status is COMMAND's (124 when interrupted at SECONDS), 2 for a bad call (also a
# machine without the wheels: python3 misses a module of $NEEDS, default "mujoco distrax"), or 3
# where RESUME=1 finds nothing to resume.
set -uo pipefail
if [ $# -lt 4 ]; then
  echo "usage: bash benchmarks/device_call.sh NAME RUN_DIR SECONDS COMMAND [ARG ...]" >&2
  exit 2
fi
name=$1 run_dir=$2 seconds=$3
shift 3
case $seconds in
  ''|*[!0-9]*) echo "device_call: SECONDS must be a whole number of seconds, got '$seconds'" >&2
               exit 2 ;;
esac
if [ -z "${OUT:-}" ]; then
  echo "device_call: \$OUT, the folder whose files come back, is not set" >&2
  exit 2
fi
out=$OUT
here=$(cd "$(dirname "$0")" && pwd)
carry_dir=${CARRY_ROOT:-.carry}/$name
stage=${STAGE_ROOT:-/tmp}/stage-$name
send_lock=${STAGE_ROOT:-/tmp}/blx-send.lock
site=${SITE_DIR:-/tmp/site}
mkdir -p "$out"
log=$out/$name.log

# Takes the lock LOCK (a directory) from calls side by side, waiting at most SECONDS for it: a lock
# left by a call killed while holding it is then passed over.
take() {  # LOCK SECONDS
  for _ in $(seq "$2"); do mkdir "$1" 2>/dev/null && return; sleep 1; done
}

# 1. Wheels, once per machine; calls side by side (one per GPU) install them once, in turn.
mkdir -p "$(dirname "$site")"
take "$site.lock" 120
for wheels in .whl-train .whl; do
  if [ -d "$wheels" ] && ! [ -e "$site/.blx-installed" ]; then
    if ! python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target "$site" "$wheels"/*.whl >> "$log" 2>&1; then
      rmdir "$site.lock"
      echo "device_call: installing $wheels into $site failed (see $log)" >&2
      exit 2
    fi
    touch "$site/.blx-installed"
    echo "[device_call] installed $wheels into $site" | tee -a "$log"
    break
  fi
done
rmdir "$site.lock" 2>/dev/null
export PYTHONPATH=$site:$PWD${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
# A machine without the wheels (a fresh one: the last went back between calls, after 30 s idle)
# cannot train: say so now, rather than in a traceback of the first import.
missing=$(python3 -c 'import importlib.util as u, sys
print(" ".join(m for m in sys.argv[1:] if u.find_spec(m) is None))' ${NEEDS:-mujoco distrax})
if [ -n "$missing" ]; then
  echo "device_call: python3 finds no $missing here: this machine has no wheels installed (a" \
    "fresh machine? the last one goes back after 30 s idle) and none were carried; carry" \
    ".whl-train, and the run's last parts ($carry_dir)" | tee -a "$log" >&2
  exit 2
fi

# 2. Resume from carried parts.
if ! [ -e "$run_dir" ]; then
  parts=$(ls "$carry_dir/$name".tar.part_* 2>/dev/null)
  if [ -n "$parts" ]; then
    # shellcheck disable=SC2086  # the parts' names hold no spaces (carry.py writes them)
    python3 "$here/carry.py" unpack $parts --into "$run_dir" 2>&1 | tee -a "$log" || exit 2
  elif [ "${RESUME:-0}" = 1 ]; then
    echo "device_call: RESUME=1, but neither $run_dir nor parts of $name in $carry_dir are" \
      "here; carry $carry_dir (carry.py unpark $name --into $carry_dir)" | tee -a "$log" >&2
    exit 3
  else
    echo "[device_call] $run_dir is new: no parts of $name in $carry_dir" | tee -a "$log"
  fi
fi

# Sends the staged parts into $OUT, one call at a time: each fits its parts beside the files
# already there.
send_stage() {
  take "$send_lock" 60
  python3 "$here/carry.py" send "$stage" "$out" 2>&1 | tee -a "$log"
  rmdir "$send_lock" 2>/dev/null
}

# What RUN_DIR holds: every file's path and content, as one digest ("" where there is none);
# provenance.json left out: a process that trained nothing (one that failed before its first chunk
# ended) still records there that it ran, and its run is not worth the room of a pack.
fingerprint() {
  [ -d "$run_dir" ] || return 0
  (cd "$run_dir" && find . -type f ! -name provenance.json -print0 | LC_ALL=C sort -z \
    | xargs -0 -r md5sum | md5sum)
}

# 3. Train until the deadline. BLX_STOP_BY (blx.training's time limit, unless the call gives its
#    own) is 15 s before it, room for the last segment's checkpoint: blx's training stops by
#    itself after the last segment that ends in time, and the call returns that much sooner.
found=$(fingerprint)
echo "[device_call] $(date -u +%FT%TZ) running for at most ${seconds} s: $*" | tee -a "$log"
BLX_STOP_BY=${BLX_STOP_BY:-$(( $(date +%s) + seconds - 15 ))} \
  timeout -s INT -k 30 "$seconds" "$@" >> "$log" 2>&1
status=$?
echo "[device_call] $(date -u +%FT%TZ) exit status $status" | tee -a "$log"

# 4. Carry back, where there is a checkpoint to resume from: a new run stopped before its first
#    chunk ended has none, and its pack would only take a file of the call's return.
if [ -d "$run_dir" ] && [ -z "$(find "$run_dir" -path '*/checkpoint/*' -type f -print -quit)" ]
then
  echo "[device_call] $run_dir holds no checkpoint (its first chunk did not end within" \
    "${seconds} s): nothing to carry back; give a new run a longer stretch" | tee -a "$log"
elif [ -d "$run_dir" ] && [ -n "$found" ] && [ "$(fingerprint)" = "$found" ]; then
  echo "[device_call] $run_dir is as this call found it: not packed again (its last pack holds" \
    "it)" | tee -a "$log"
  if [ -n "$(ls "$stage"/"$name".tar.part_* 2>/dev/null)" ]; then
    send_stage
  fi
elif [ -d "$run_dir" ]; then
  rm -rf "$stage"
  if python3 "$here/carry.py" pack "$run_dir" "$stage" --name "$name" 2>&1 | tee -a "$log"; then
    send_stage
  fi
fi
exit $status
