#!/usr/bin/env bash
# The GPU figures and checks of docs/backends.md in one run: the GPU-only tests, the
# env, terms and training benches at 4096 and 8192 envs, and a short training run.
# Needs a CUDA GPU and the warp extra (scripts/setup.sh installs it); runs the package
# as a module, so an uninstalled checkout on PYTHONPATH works too.
# Usage: bash scripts/gpu_check.sh [OUT_DIR]   (default results/gpu: each part's output)
# Every part runs even when one before it fails; the exit status counts the failed parts.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:-results/gpu}
py=${PYTHON:-python}  # the interpreter (PYTHON=python3 where there is no 'python')
"$py" -c "import sys, torch; sys.exit(0 if torch.cuda.is_available() else \
'gpu_check: no CUDA GPU (torch.cuda.is_available() is False)')" || exit 1
mkdir -p "$out"
failed=0
part() {  # name, then the command; its output to OUT_DIR/name.txt, its last line shown
    local name=$1; shift
    echo "== $name"
    "$@" > "$out/$name.txt" 2>&1 || { failed=$((failed + 1)); echo "FAILED: $name"; }
    tail -1 "$out/$name.txt"
}
hr=("$py" -m hybrid_recovery.cli.main)
part gpu nvidia-smi --query-gpu=name,memory.total --format=csv,noheader
part tests "$py" -m pytest -q -p no:cacheprovider -k "gpu or cuda" \
    tests/test_warp_parity.py tests/test_step_state.py
part bench_env_4096 "${hr[@]}" bench env --backend warp --device cuda -n 4096
part bench_env_8192 "${hr[@]}" bench env --backend warp --device cuda -n 8192
part bench_terms_4096 "${hr[@]}" bench terms --device cuda -n 4096
part bench_train_4096 "${hr[@]}" bench train --backend warp --device cuda -n 4096
part train_4096 "${hr[@]}" train --variant recovery --backend warp --device cuda \
    --num-envs 4096 --iterations 3 --run-dir "$out/train_run" --force
echo "gpu_check: $failed part(s) failed; outputs in $out"
exit "$failed"
