"""Swing-foot trajectory: quintic in the plane, re-targetable, with a smooth apex bump.

Horizontal (x, y): a quintic from the current (p, ṗ, p̈) to (p_target, 0, 0) that ends at
a fraction ``plane_fraction`` of the swing (the sole is above its target before it comes
down, so an early touchdown lands on target); re-targeting restarts it from the
trajectory's own state so that the reference stays C².
Vertical: z(s) = z₀ + (z₁ − z₀) b(s) + h_apex · 64 s³ (1 − s)³ with the minimum-jerk
blend b(s) = 10 s³ − 15 s⁴ + 6 s⁵ and s = (t − t₀)/T; the bump peaks at h_apex at s = ½
with zero velocity and acceleration at both ends. After t₀ + T the reference holds the
target.

placo 0.10 has swing trajectories too (``placo.SwingFoot`` cubic with
``remake_trajectory`` to re-target, ``placo.SwingFootQuintic`` without), but they return
position and velocity only — no acceleration feed-forward for this acceleration-level QP
task — and cannot end the horizontal motion before touchdown; these 80 lines do both, so
placo is not used here.
"""

from __future__ import annotations

import numpy as np


def _quintic(p0: np.ndarray, v0: np.ndarray, a0: np.ndarray, p1: np.ndarray, duration: float
             ) -> np.ndarray:
    """Coefficients c (6, D) of p(τ) = Σ c_k τ^k from (p0, v0, a0) to (p1, 0, 0) at τ = T."""
    t = max(duration, 1e-3)
    dp = p1 - p0
    c3 = (20 * dp - 12 * v0 * t - 3 * a0 * t**2) / (2 * t**3)
    c4 = (-30 * dp + 16 * v0 * t + 3 * a0 * t**2) / (2 * t**4)
    c5 = (12 * dp - 6 * v0 * t - a0 * t**2) / (2 * t**5)
    return np.stack([p0, v0, a0 / 2, c3, c4, c5])


def _eval(coef: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    powers = tau ** np.arange(6)
    pos = powers @ coef
    vel = (np.arange(1, 6) * powers[:5]) @ coef[1:]
    acc = (np.array([2, 6, 12, 20]) * powers[:4]) @ coef[2:]
    return pos, vel, acc


class SwingTrajectory:
    """Sole-centre reference p(t), ṗ(t), p̈(t) of one swing, world frame.

    Args:
        start: Sole centre at lift-off, shape (3,) [m].
        target: Touchdown sole centre, shape (3,) [m].
        t_start: Lift-off time t₀ [s].
        duration: Swing time T > 0 [s].
        height: Apex height h_apex above the straight line [m].
        plane_fraction: Fraction of T at which the horizontal motion ends, in (0, 1].
    """

    def __init__(self, start: np.ndarray, target: np.ndarray, t_start: float, duration: float,
                 height: float, plane_fraction: float = 0.85) -> None:
        if duration <= 0.0:
            raise ValueError("swing duration must be > 0")
        if not 0.0 < plane_fraction <= 1.0:
            raise ValueError("plane_fraction must be in (0, 1]")
        self._t_plane_end = t_start + plane_fraction * duration
        self.start = np.asarray(start, dtype=float).copy()
        self.target = np.asarray(target, dtype=float).copy()
        self.t_start, self.duration, self.height = t_start, duration, height
        self._t_plan = t_start
        zero = np.zeros(2)
        self._xy = _quintic(self.start[:2], zero, zero, self.target[:2],
                            self._t_plane_end - t_start)

    @property
    def t_end(self) -> float:
        """Planned touchdown time t₀ + T [s]."""
        return self.t_start + self.duration

    def phase(self, t: float) -> float:
        """s = (t − t₀)/T, not clipped."""
        return (t - self.t_start) / self.duration

    def retarget(self, t: float, target: np.ndarray) -> None:
        """Moves the touchdown point; the plane quintic restarts from its state at t."""
        if t >= self._t_plane_end - 1e-3:
            return
        pos, vel, acc = _eval(self._xy, t - self._t_plan)
        self.target = np.asarray(target, dtype=float).copy()
        self._xy = _quintic(pos, vel, acc, self.target[:2], self._t_plane_end - t)
        self._t_plan = t

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p, ṗ, p̈) at time t, each shape (3,) [m, m/s, m/s²]."""
        t = min(max(t, self.t_start), self.t_end)
        if t >= self._t_plane_end:
            xy, vxy, axy = self.target[:2], np.zeros(2), np.zeros(2)
        else:
            xy, vxy, axy = _eval(self._xy, t - self._t_plan)
        s, T = self.phase(t), self.duration
        z0, z1, h = self.start[2], self.target[2], self.height
        blend = (10 * s**3 - 15 * s**4 + 6 * s**5, (30 * s**2 - 60 * s**3 + 30 * s**4) / T,
                 (60 * s - 180 * s**2 + 120 * s**3) / T**2)
        bump = (64 * s**3 * (1 - s) ** 3,
                64 * (3 * s**2 * (1 - s) ** 3 - 3 * s**3 * (1 - s) ** 2) / T,
                64 * (6 * s * (1 - s) ** 3 - 18 * s**2 * (1 - s) ** 2 + 6 * s**3 * (1 - s))
                / T**2)
        z = [z0 * (k == 0) + (z1 - z0) * b + h * u for k, (b, u) in enumerate(zip(blend, bump,
                                                                                    strict=True))]
        return (np.array([*xy, z[0]]), np.array([*vxy, z[1]]), np.array([*axy, z[2]]))
