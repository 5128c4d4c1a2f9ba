"""Compiled loops: the same results, with or without numba's disk cache."""

from __future__ import annotations

import numba
import numpy as np

from hybrid_recovery.dynamics.compiled import compiled


def _twice(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.size):
        out[i] = 2.0 * x[i]


def test_a_loop_compiles_and_runs():
    x, out = np.arange(5.0), np.empty(5)
    compiled(_twice)(x, out)
    np.testing.assert_array_equal(out, 2.0 * x)


def test_without_a_writable_cache_it_compiles_in_memory(monkeypatch):
    real = numba.njit
    calls = []

    def njit(**options):
        calls.append(options.get("cache", False))
        if options.get("cache"):
            raise RuntimeError("cannot cache function '_twice': no locator available")
        return real(**options)

    monkeypatch.setattr(numba, "njit", njit)
    x, out = np.arange(3.0), np.empty(3)
    compiled(_twice)(x, out)
    assert calls == [True, False]
    np.testing.assert_array_equal(out, 2.0 * x)
