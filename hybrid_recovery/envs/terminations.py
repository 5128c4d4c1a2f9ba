"""Terminations (paper §III-F, stuck low §IV-B) and the paper's success criterion (§IV-A3)."""

from __future__ import annotations

import math

import numpy as np
from array_api_compat import array_namespace

from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT

TERMINATIONS = ("timeout", "torso_contact", "stuck_low", "nan")
"""Termination causes logged as ``termination/<name>``."""

SUCCESS_VERTICAL_SPEED = 0.1
"""|ḣ_c| below which it counts as steady [m/s]."""
SUCCESS_TILT = math.radians(72.0)
"""Torso tilt from vertical within which it counts as upright [rad]."""
SUCCESS_TIME = 1.0
"""How long all three must hold [s]."""


def upright(height: Array, height_vel: Array, gravity_b: Array, still: bool = True) -> Array:
    """The paper's standing condition at one instant, shape (N,) bool (numpy or torch).

    Args:
        height: CoM height h_c (N,) [m]; height_vel: ḣ_c (N,) [m/s];
        gravity_b: torso projected gravity (N, 3); tilt = arccos(−g_b,z).
        still: include the |ḣ_c| < 0.1 m/s clause (False: up and upright only).
    """
    xp = array_namespace(height, height_vel, gravity_b)
    ok = (height > UPRIGHT_COM_HEIGHT) & (-gravity_b[..., 2] > math.cos(SUCCESS_TILT))
    return ok & (xp.abs(height_vel) < SUCCESS_VERTICAL_SPEED) if still else ok


def success_step(upright_time: Array, state: dict, dt: float, still: bool = True) -> Array:
    """Time the standing condition has held without a break, after one step [s]."""
    ok = upright(state["height"], state["height_vel"], state["gravity_b"], still)
    return array_namespace(upright_time).where(ok, upright_time + dt, 0.0)


class StuckLow:
    """Stuck-low: while not upright, the CoM is less than ``rise`` above its lowest point
    of the last ``duration`` seconds (and the episode is at least that old).

    Measuring the rise from the window's minimum makes a fall followed by a stand-up
    attempt not stuck, and lying still stuck after ``duration``; small oscillations of
    the CoM do not reset anything (each trough is a new minimum), so wiggling on the
    ground cannot postpone the termination.
    """

    def __init__(self, num_envs: int, duration: float, rise: float, dt: float = 0.02) -> None:
        self.duration, self.rise, self.dt = duration, rise, dt
        self.enabled = bool(np.isfinite(duration))  # duration = inf switches it off
        steps = int(round(duration / dt)) if self.enabled else 0
        self.window = max(1, steps) + 1  # samples spanning [t − T, t]
        self.heights = np.zeros((num_envs, self.window))
        self.steps = np.zeros(num_envs, dtype=int)

    def reset(self, ids: np.ndarray, height: np.ndarray) -> None:
        self.heights[ids] = np.asarray(height)[:, None]
        self.steps[ids] = 1  # the reset height is the first sample

    def update(self, height: np.ndarray, dt: float, low: np.ndarray) -> np.ndarray:
        """Adds one sample (every ``dt`` = the construction's dt); returns the stuck envs."""
        del dt
        self.heights[np.arange(len(self.steps)), self.steps % self.window] = height
        self.steps += 1
        full = self.steps >= self.window
        return low & full & self.enabled & (height - self.heights.min(axis=1) < self.rise)
