#!/usr/bin/env bash
# Starts, or resumes, a training run in the background at the lowest CPU priority.
#   training/run_background.sh [VARIANT] [RUN_DIR] [extra train options...]
# Without arguments it trains the recipe (--variant recovery_rises, in stages) in
# runs/recovery_rises. Progress: tail -f RUN_DIR.log ; curves: tensorboard --logdir RUN_DIR
# Stop: kill PID (the iteration under way finishes and is saved; run this again to resume).
set -euo pipefail
variant=${1:-recovery_rises}
run_dir=${2:-runs/$variant}
shift $(( $# > 2 ? 2 : $# ))
if ! command -v hybrid-recovery >/dev/null; then
  echo "run_background.sh: hybrid-recovery is not on PATH; activate the project's environment" \
       "first (. .venv/bin/activate)" >&2
  exit 1
fi
resume=()
[ -f "$run_dir/latest.pt" ] && resume=(--resume)
mkdir -p "$(dirname "$run_dir")"
nohup nice -n 19 hybrid-recovery train --variant "$variant" --run-dir "$run_dir" \
  "${resume[@]}" "$@" >> "$run_dir.log" 2>&1 &
pid=$!
sleep 3
if ! kill -0 "$pid" 2>/dev/null; then
  echo "run_background.sh: the run ended at once; the end of $run_dir.log:" >&2
  tail -n 20 "$run_dir.log" >&2
  exit 1
fi
echo "training $variant in $run_dir (pid $pid, log $run_dir.log; stop, saved: kill $pid)"
