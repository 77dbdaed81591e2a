#!/usr/bin/env bash
# Session 5 GPU job: is the MJX ant's top speed limited by the physics settings?
# GPU 0: task PPO on ant_run (target (4, 0)), 2 seeds x 30 M steps, four physics settings side by side.
# GPU 1: GAIL (5 seeds, the paper's 60 M steps) on the most accurate setting; then GCRL on GPU 0.
# Launch detached: setsid nohup bash benchmarks/ant_speed_job.sh RESULT_DIR > log 2>&1 &
# Session 5 ran it as written, then stopped the two 4-iteration ant_run arms (a tenth of the speed
# of the others on the shared GPU; they could not finish) and, instead of GCRL, ran on GPU 0:
#   paper_tables.py --seeds 5 --objective gail --env-edits "$D5" --out RESULT_DIR/gail_d5
set -u
R=${1:?result dir}; mkdir -p "$R"
# Every arm names its physics (the ant's default was 10 ms x 5 when this ran; it is 5 ms x 10 now).
MS10='{"global_options": {"timestep": 0.01, "substeps": 5, "iterations": 1}}'
D5='{"global_options": {"timestep": 0.005, "substeps": 10, "iterations": 1}}'
I4='{"global_options": {"timestep": 0.01, "substeps": 5, "iterations": 4}}'
D5I4='{"global_options": {"timestep": 0.005, "substeps": 10, "iterations": 4}}'
arm() {  # name edits
  local e=""; [ -n "$2" ] && e="edits=$2"
  XLA_PYTHON_CLIENT_MEM_FRACTION=0.22 python3 -m blx.experiments.cli train --env ant_run --objective task \
    --seeds 0,1 --steps 30000000 ${e:+--env-param "$e"} --out "$R/ant_run_$1" > "$R/ant_run_$1.log" 2>&1
}
export -f arm; export R MS10 D5 I4 D5I4
DEADLINE_S=${DEADLINE_S:-1380} LOG_DIR=$R bash benchmarks/on_gpus.sh \
  "arm base \"\$MS10\" & arm d5 \"\$D5\" & arm i4 \"\$I4\" & arm d5i4 \"\$D5I4\" & wait ;; python3 benchmarks/paper_tables.py --seeds 5 --objective gcrl --env-edits \"\$D5I4\" --out $R/gcrl_d5i4" \
  "python3 benchmarks/paper_tables.py --seeds 5 --objective gail --env-edits \"\$D5I4\" --out $R/gail_d5i4"
echo done > "$R/DONE"
