"""The DC motor model in the physics batch: the actuators' force ranges follow the
torque–speed curve (:func:`hybrid_recovery.robot.actuator.dc_torque_limits`), rewritten
from the joint speeds before every physics substep."""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.robot.actuator import dc_torque_limits
from hybrid_recovery.robot.constants import VELOCITY_LIMITS


class DcMotors:
    """Writes each simulation's available torque interval into its actuator force ranges.

    Args:
        force_range: the batch's per-simulation ``actuator_forcerange``, (N, 27, 2) [N·m],
            live; its upper bounds at an episode's reset are that episode's τ_lim (the
            torque curriculum's scale included).
        qvel: the batch's joint speeds, (N, nv), live.
        model: the nominal model (actuator i drives ``constants.JOINT_NAMES[i]``).
        saturation_ratio: τ_sat / τ_lim.
    """

    def __init__(self, force_range: np.ndarray, qvel: np.ndarray, model: mujoco.MjModel,
                 saturation_ratio: float) -> None:
        self.force_range, self.qvel = force_range, qvel
        self.dadr = model.jnt_dofadr[model.actuator_trnid[:, 0]]
        self.effort = np.abs(force_range[:, :, 1]).copy()
        """τ_lim of each simulation's episode, (N, 27) [N·m]."""
        self.saturation_ratio = saturation_ratio

    def reset(self, ids: np.ndarray) -> None:
        """Reads the new episodes' τ_lim from their (freshly set) force ranges."""
        self.effort[ids] = np.abs(self.force_range[ids, :, 1])

    def apply(self) -> None:
        """Writes the interval available at the present joint speeds (before a substep)."""
        low, high = dc_torque_limits(self.qvel[:, self.dadr], self.effort,
                                     VELOCITY_LIMITS, self.saturation_ratio)
        self.force_range[:, :, 0] = low
        self.force_range[:, :, 1] = high
