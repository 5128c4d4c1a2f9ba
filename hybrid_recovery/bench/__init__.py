"""Benchmarks behind ``hybrid-recovery bench <what>``: one module per target.

Every target is a function ``run_<what>_bench(n=..., repeat=..., seed=...)`` returning a
:class:`BenchResult`; the CLI passes only the options given on its command line, so each
target keeps its own defaults (``n`` is the problem size: states, envs, ...).
"""

from __future__ import annotations

from collections.abc import Callable

from hybrid_recovery.bench.dynamics import run_dynamics_bench
from hybrid_recovery.bench.env import run_env_bench
from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.terms import run_terms_bench
from hybrid_recovery.bench.train import run_train_bench

BENCHES: dict[str, Callable[..., BenchResult]] = {
    "dynamics": run_dynamics_bench,
    "env": run_env_bench,
    "terms": run_terms_bench,
    "train": run_train_bench,
}
"""Bench targets by name, the choices of ``hybrid-recovery bench``."""

__all__ = ["BENCHES", "BenchResult", "run_dynamics_bench", "run_env_bench", "run_terms_bench",
           "run_train_bench"]
