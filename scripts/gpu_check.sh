#!/usr/bin/env bash
# The GPU figures and checks of docs/backends.md in one run: the GPU-only tests, the
# env, terms and training benches at 4096 and 8192 envs, and a short training run.
# Needs a CUDA GPU and the warp extra (scripts/setup.sh installs it); runs the package
# as a module, so an uninstalled checkout on PYTHONPATH works too.
# Usage: bash scripts/gpu_check.sh [OUT_DIR]   (default results/gpu; each bench's JSON)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-results/gpu}
python -c "import sys, torch; sys.exit(0 if torch.cuda.is_available() else \
'gpu_check: no CUDA GPU (torch.cuda.is_available() is False)')"
mkdir -p "$out"
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader | tee "$out/gpu.txt"
python -m pytest -q -p no:cacheprovider -k "gpu or cuda" tests/test_warp_parity.py \
    tests/test_step_state.py | tail -3 | tee "$out/tests.txt"
bench() {  # name, then the bench's arguments; its last line is JSON
    local name=$1; shift
    python -m hybrid_recovery.cli.main bench "$@" | tail -1 | tee "$out/$name.json"
}
bench env_4096 env --backend warp --device cuda -n 4096
bench env_8192 env --backend warp --device cuda -n 8192
bench terms_4096 terms --device cuda -n 4096
bench train_4096 train --backend warp --device cuda -n 4096
python -m hybrid_recovery.cli.main train --variant recovery --backend warp --device cuda \
    --num-envs 4096 --iterations 3 --run-dir "$out/train_run" --force 2>&1 | tail -25 | tee "$out/train.txt"
