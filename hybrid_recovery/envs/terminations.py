"""Terminations (SPEC §5) and the paper's success criterion (SPEC §7)."""

from __future__ import annotations

import numpy as np

TERMINATIONS = ("timeout", "torso_contact", "stuck_low", "nan")
"""Termination causes logged as ``termination/<name>``."""

SUCCESS_HEIGHT = 0.85
"""CoM height above which a robot counts as up [m]."""
SUCCESS_VERTICAL_SPEED = 0.1
"""|ḣ_c| below which it counts as steady [m/s]."""
SUCCESS_TILT = np.deg2rad(72.0)
"""Torso tilt from vertical within which it counts as upright [rad]."""
SUCCESS_TIME = 1.0
"""How long all three must hold [s]."""


def upright(height: np.ndarray, height_vel: np.ndarray, gravity_b: np.ndarray) -> np.ndarray:
    """The paper's standing condition at one instant, shape (N,) bool.

    Args:
        height: CoM height h_c (N,) [m]; height_vel: ḣ_c (N,) [m/s];
        gravity_b: torso projected gravity (N, 3); tilt = arccos(−g_b,z).
    """
    tilt_ok = -gravity_b[..., 2] > np.cos(SUCCESS_TILT)
    return (height > SUCCESS_HEIGHT) & (np.abs(height_vel) < SUCCESS_VERTICAL_SPEED) & tilt_ok


def success_step(upright_time: np.ndarray, state: dict, dt: float) -> np.ndarray:
    """Time the standing condition has held without a break, after one step [s]."""
    ok = upright(state["height"], state["height_vel"], state["gravity_b"])
    return np.where(ok, upright_time + dt, 0.0)


class StuckLow:
    """Stuck-low: the CoM has not risen by ``rise`` for ``duration`` while not upright.

    The reference height follows the CoM down and is reset on every rise of ``rise``
    above it, so a fall followed by a stand-up attempt is not stuck, but lying still is.
    """

    def __init__(self, num_envs: int, duration: float, rise: float) -> None:
        self.duration, self.rise = duration, rise
        self.reference = np.zeros(num_envs)
        self.timer = np.zeros(num_envs)

    def reset(self, ids: np.ndarray, height: np.ndarray) -> None:
        self.reference[ids] = height
        self.timer[ids] = 0.0

    def update(self, height: np.ndarray, dt: float, low: np.ndarray) -> np.ndarray:
        """Advances by dt; returns the envs that are stuck low, shape (N,) bool."""
        rose = height > self.reference + self.rise
        self.reference = np.where(rose, height, np.minimum(self.reference, height))
        self.timer = np.where(rose | ~low, 0.0, self.timer + dt)
        return self.timer >= self.duration
