#!/usr/bin/env bash
# The test command of the README: lint, type-check, then the whole test suite, one pytest
# worker per CPU (pytest-xdist).
set -euo pipefail
cd "$(dirname "$0")/.."
ruff check hybrid_recovery tests deploy research
mypy hybrid_recovery
MUJOCO_GL=${MUJOCO_GL:-egl} python -m pytest -q -p no:cacheprovider -n auto --durations=15
