"""Periodic loops on an absolute schedule, their timing statistics, and real-time priority."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np


def try_realtime(priority: int = 50) -> str:
    """Ask for SCHED_FIFO at ``priority`` for this process; returns what was obtained.

    A control loop at normal priority shares the cores with everything else; SCHED_FIFO
    (Linux, needs CAP_SYS_NICE or root) preempts normal tasks as soon as it wakes.
    """
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (AttributeError, PermissionError, OSError) as err:
        return f"normal (SCHED_FIFO refused: {err})"
    return f"SCHED_FIFO {priority}"


class PeriodicClock:
    """Wakes at t₀ + k·period (absolute, so lateness does not accumulate).

    ``wait()`` sleeps to the next deadline and returns the wake time; a deadline already
    passed returns at once and the schedule is not shifted (a late tick is caught up, never
    skipped: the state machine sees the long gap and faults on overruns).
    """

    def __init__(self, period_s: float, start: float | None = None) -> None:
        self.period = period_s
        self.t0 = time.monotonic() if start is None else start
        self.k = 0

    @property
    def deadline(self) -> float:
        """The next deadline, ``time.monotonic()`` seconds."""
        return self.t0 + self.k * self.period

    def wait(self) -> float:
        """Sleeps until the next deadline; returns the wake time and advances the schedule."""
        remaining = self.deadline - time.monotonic()
        if remaining > 0:
            time.sleep(remaining)
        self.k += 1
        return time.monotonic()


@dataclass
class LoopStats:
    """Per-tick timings of a periodic loop [s]."""

    period_s: float
    wake: list[float] = field(default_factory=list)
    """Wake times."""
    deadline: list[float] = field(default_factory=list)
    """Scheduled times."""
    compute: list[float] = field(default_factory=list)
    """Wake → command written."""
    inference: list[float] = field(default_factory=list)
    """ONNX inference only (ticks that ran the policy)."""

    def summary(self) -> dict[str, float]:
        """Median / p99 / max in milliseconds, and tick counts.

        ``lateness`` = wake − deadline; ``period_jitter`` = |wake_k − wake_{k−1} − period|;
        ``send_lateness`` = command written − deadline (lateness + compute).
        """
        wake, deadline = np.asarray(self.wake), np.asarray(self.deadline)
        compute = np.asarray(self.compute)
        out: dict[str, float] = {"ticks": float(len(wake))}
        series = {"lateness": wake - deadline,
                  "period_jitter": np.abs(np.diff(wake) - self.period_s),
                  "send_lateness": wake - deadline + compute if len(compute) else compute,
                  "compute": compute,
                  "inference": np.asarray(self.inference)}
        for name, values in series.items():
            if len(values) == 0:
                continue
            ms = 1e3 * values
            out[f"{name}_median_ms"] = float(np.median(ms))
            out[f"{name}_p99_ms"] = float(np.percentile(ms, 99))
            out[f"{name}_max_ms"] = float(np.max(ms))
        return out
