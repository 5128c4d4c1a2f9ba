"""The paper's success criterion on a trajectory (paper §IV-A3) and recovery time.

A trial succeeds when the CoM is above 0.85 m with |ḣ_c| < 0.1 m/s and torso tilt within
72° of vertical, all holding without a break for at least 1 s. The instantaneous
condition is :func:`hybrid_recovery.envs.terminations.upright`, shared with training.
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.envs.config import EnvConfig
from hybrid_recovery.envs.terminations import SUCCESS_TIME, StuckLow, upright


def recovery_time(time: np.ndarray, height: np.ndarray, height_vel: np.ndarray,
                  gravity_b: np.ndarray, hold: float = SUCCESS_TIME,
                  start: float = 0.0) -> float | None:
    """Time from ``start`` to the beginning of the first ≥ ``hold`` s stretch of the
    standing condition that begins at or after ``start``.

    A pushed trial counts from the end of the push: standing before it proves nothing.

    Args:
        time: sample times t, shape (T,) [s], uniformly spaced.
        height: CoM height h_c, (T,) [m].
        height_vel: ḣ_c, (T,) [m/s].
        gravity_b: torso projected gravity, (T, 3).
        hold: how long the condition must hold [s].
        start: time from which recovery is measured [s].

    Returns:
        The recovery time [s], or None (failure).
    """
    ok = upright(height, height_vel, gravity_b) & (time >= start - 1e-9)
    if len(time) < 2:
        return None
    dt = float(time[1] - time[0])
    need = int(np.ceil(hold / dt - 1e-9))
    run = 0
    for k, flag in enumerate(ok):
        run = run + 1 if flag else 0
        if run >= need:
            return max(0.0, float(time[k - run + 1] - start))
    return None


def stuck_low(height: np.ndarray, dt: float) -> bool:
    """Whether the training env's stuck-low termination (paper §IV-B, :class:`StuckLow` with
    the default :class:`EnvConfig`) would have ended this trajectory: below the upright
    height, the CoM rose less than ``stuck_rise`` above its lowest point of the last
    ``stuck_time`` seconds. The paper's ablation reports its rate (full 0.067, reduced 1.0).

    Args:
        height: CoM height h_c, shape (T,) [m], sampled every ``dt`` [s].
    """
    cfg = EnvConfig()
    detector = StuckLow(1, cfg.stuck_time, cfg.stuck_rise, dt)
    h = np.asarray(height, dtype=float)
    if not len(h):
        return False
    detector.reset(np.array([0]), h[:1])
    for value in h[1:]:
        sample = np.array([value])
        if detector.update(sample, dt, sample < cfg.upright_height)[0]:
            return True
    return False


def wilson_interval(successes: int, trials: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a success rate (valid at 0 and n successes)."""
    if trials <= 0:
        return (0.0, 1.0)
    p = successes / trials
    denom = 1 + z * z / trials
    centre = (p + z * z / (2 * trials)) / denom
    half = z * np.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / denom
    # the interval contains p exactly (rounding would leave 1 − 1e-16 at n of n)
    return (float(min(p, max(0.0, centre - half))), float(max(p, min(1.0, centre + half))))
