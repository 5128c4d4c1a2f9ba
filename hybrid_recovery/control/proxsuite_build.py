"""proxsuite (ProxQP), loaded from its build without explicit AVX2 / AVX-512 code.

proxsuite ships three builds of its extension and loads the widest one the CPU runs. The
AVX2 and AVX-512 builds do not return the same bits for the same QP from one process to
the next (one double-support problem of the balance QP: solutions ~1e-13 apart, as the
heap lies), and the model-based rises and moves are chaotic enough to turn that into
another outcome: ``eval --controller model`` gave another trial list on every run, and
four runs of one kneeling start four trajectories. The build without them (Eigen's x86-64
default, SSE2) returns the same bits every time, for ~20 % more solve time
(``docs/experiments.md`` §15). Every QP of the project imports proxsuite from here; this
module must load it before anything else does (``qpsolvers`` does at import).
"""

from __future__ import annotations

import sys
import types
import warnings
from typing import TYPE_CHECKING

PORTABLE_BUILD = "proxsuite_pywrap"
"""The extension module of proxsuite's build without explicit SIMD."""


def _load() -> types.ModuleType:
    """proxsuite, its portable build chosen when this process has not loaded it yet."""
    if "proxsuite" in sys.modules:
        return sys.modules["proxsuite"]
    # proxsuite picks its build by proxsuite.instructionset's CPU checks: answer no
    shim = types.ModuleType("proxsuite.instructionset")
    shim.has_AVX512F = shim.has_AVX2 = lambda: False  # type: ignore[attr-defined]
    sys.modules[shim.__name__] = shim
    try:
        import proxsuite
    finally:
        del sys.modules[shim.__name__]
    return proxsuite


if TYPE_CHECKING:
    import proxsuite
else:
    proxsuite = _load()
BUILD: str = proxsuite._submodule.__name__.rsplit(".", 1)[-1]
"""The extension module proxsuite runs on in this process."""
if BUILD != PORTABLE_BUILD:
    warnings.warn(f"proxsuite was loaded before hybrid_recovery's QPs with its {BUILD} build: "
                  "QP solutions may differ in their last bits from run to run (import "
                  "hybrid_recovery before qpsolvers or proxsuite)", RuntimeWarning, stacklevel=2)
