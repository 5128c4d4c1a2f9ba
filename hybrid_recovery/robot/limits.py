"""The robot's safety limits in joint order: joint ranges, effort limits, gains, default pose.

Gains, effort limits and the default pose come from :mod:`hybrid_recovery.robot.constants`;
joint ranges (not in the constants) from the robot's MJCF, by joint name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.robot import constants


@dataclass(frozen=True)
class SafetyLimits:
    """Limits the safety layer enforces, each shape (27,), joint (= motor) order.

    Attributes:
        q_min: Lower joint limits [rad].
        q_max: Upper joint limits [rad].
        effort: Effort limits τ_max [N·m].
        kp_max: Largest stiffness ever sent [N·m/rad] (the constants' KP).
        kd_max: Largest damping ever sent [N·m·s/rad] (the constants' KD).
        default_q: Default standing pose q* [rad].
    """

    q_min: np.ndarray
    q_max: np.ndarray
    effort: np.ndarray = field(default_factory=lambda: constants.EFFORT_LIMITS)
    kp_max: np.ndarray = field(default_factory=lambda: constants.KP)
    kd_max: np.ndarray = field(default_factory=lambda: constants.KD)
    default_q: np.ndarray = field(default_factory=lambda: constants.DEFAULT_JOINT_POS)

    @classmethod
    def from_robot(cls, mjcf: str | Path | None = None) -> SafetyLimits:
        """Joint ranges from an H1-2 MJCF (None: the project's), the rest from the constants."""
        from hybrid_recovery.robot.mjcf import load_mjmodel

        return cls.from_model(load_mjmodel(mjcf, floor=False, actuators=False))

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> SafetyLimits:
        """Joint ranges from a MuJoCo model of the H1-2, the rest from the constants."""
        ranges = np.array([model.jnt_range[model.joint(n).id] for n in constants.JOINT_NAMES])
        return cls(q_min=ranges[:, 0].copy(), q_max=ranges[:, 1].copy())

    def q_ref_bounds(self, factor: float) -> tuple[np.ndarray, np.ndarray]:
        """The joint ranges scaled by ``factor`` about their middle (lower, upper) [rad]."""
        mid, half = (self.q_min + self.q_max) / 2, (self.q_max - self.q_min) / 2 * factor
        return mid - half, mid + half

    def clamp_gains(self, kp: np.ndarray, kd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """kp ∈ [0, kp_max], kd ∈ [0, kd_max] elementwise."""
        return np.clip(kp, 0.0, self.kp_max), np.clip(kd, 0.0, self.kd_max)
