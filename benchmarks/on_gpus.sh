#!/usr/bin/env bash
# Runs one queue of commands per GPU, side by side, all ending by a common deadline.
#
#   DEADLINE_S=560 bash benchmarks/on_gpus.sh "cmd A1 ;; cmd A2" "cmd B1" ...
#
# Argument i is the queue of GPU i (CUDA_VISIBLE_DEVICES=i): commands separated by ";;" run one
# after another, each killed when the deadline (seconds from start) passes. Output goes to
# $LOG_DIR/gpu<i>.log (default $OUT, else the working directory). The exit status is 0 when every
# command finished in time with status 0.
#
# For runs longer than one device call, launch this in the background (setsid nohup) and poll with
# calls that each end by copying what has finished to $OUT, e.g.
#   tar czf $OUT/res.tgz --exclude='checkpoint*' -C $LOG_DIR .
# so that a machine handed back between two polls loses nothing that had finished.
#
# A machine can be handed back between any two calls, and a call lasts at most 600 s. A run longer
# than one call therefore goes as a chain of calls: train with PPOConfig checkpoint_env_state=False
# (e.g. paper_tables.py --config '{"checkpoint_env_state": false}'), end each call by copying the
# run directory to $OUT (the checkpoint cut with `split -b 15m`, as a file may be at most 16 MiB),
# and start the next call by restoring it and giving the same command: sweeps, paper_tables.py and
# `blx train --resume DIR` continue from the checkpoint. Each resume starts the envs on new episodes.
# A run that stays on one machine can keep the envs' state (the default) and shed it once done, so
# that its parameters come back for evaluation and plots:
#   python3 -c "from blx import training; training.drop_env_state('RUN_DIR/checkpoint')"
set -u
if [ $# -eq 0 ]; then
  echo "usage: DEADLINE_S=560 bash benchmarks/on_gpus.sh \"queue of GPU 0\" [\"queue of GPU 1\" ...]" >&2
  exit 2
fi
deadline=$(( $(date +%s) + ${DEADLINE_S:-560} ))
log_dir=${LOG_DIR:-${OUT:-.}}
mkdir -p "$log_dir"
run_queue() {
  local gpu=$1 queue=$2 status=0 cmd left
  while [ -n "$queue" ]; do
    cmd=${queue%%;;*}
    if [ "$cmd" = "$queue" ]; then queue=""; else queue=${queue#*;;}; fi
    left=$(( deadline - $(date +%s) ))
    if [ "$left" -le 5 ]; then
      echo "[on_gpus] gpu $gpu: no time left for: $cmd"; status=124; continue
    fi
    echo "[on_gpus] gpu $gpu: $cmd (at most ${left}s)"
    start=$(date +%s)
    CUDA_VISIBLE_DEVICES=$gpu timeout "$left" bash -c "$cmd"
    rc=$?
    echo "[on_gpus] gpu $gpu: status $rc after $(( $(date +%s) - start ))s"
    [ "$rc" -ne 0 ] && status=$rc
  done
  return $status
}
pids=()
gpu=0
for queue in "$@"; do
  run_queue "$gpu" "$queue" >"$log_dir/gpu$gpu.log" 2>&1 &
  pids+=($!)
  gpu=$(( gpu + 1 ))
done
overall=0
for pid in "${pids[@]}"; do
  wait "$pid" || overall=1
done
exit $overall
