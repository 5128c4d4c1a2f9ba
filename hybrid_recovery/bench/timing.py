"""Wall-clock timing of a callable: best of several runs after a warm-up."""

from __future__ import annotations

import time
from collections.abc import Callable


def best_seconds(fn: Callable[[], object], repeat: int) -> float:
    """Shortest wall time of ``repeat`` calls of ``fn()`` after one untimed warm-up [s].

    The minimum, not the mean, is the figure least disturbed by other processes
    (the ``timeit`` convention).

    Raises:
        ValueError: When repeat < 1.
    """
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    fn()
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def device_sync(device: str) -> Callable[[], None] | None:
    """What ends a timed part on ``device``: a GPU's queue drained (None on the CPU)."""
    if device != "cuda":
        return None
    import torch

    return torch.cuda.synchronize
