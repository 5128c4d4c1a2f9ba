#!/usr/bin/env bash
# The test command of the README: lint, type-check, then the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
ruff check hybrid_recovery tests deploy research
mypy hybrid_recovery
MUJOCO_GL=${MUJOCO_GL:-egl} python -m pytest -q -p no:cacheprovider
