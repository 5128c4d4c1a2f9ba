#!/usr/bin/env bash
# Installs hybrid_recovery and its pinned stack into the active Python environment.
# torch 2.13.0 first: on CPU machines it resolves to the local CPU build; the
# rest then installs no second torch.
set -euo pipefail
cd "$(dirname "$0")/.."
python -m pip install -q --upgrade pip
python -m pip install -q "torch==2.13.0"
# warp: MuJoCo Warp, the GPU physics backend; on the CPU device it runs the parity tests
python -m pip install -q -e ".[dev,deploy,warp]"
