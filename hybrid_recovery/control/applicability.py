"""When the QP balance controller applies: a finite state, the robot up on its feet.

The QP's model is a robot on its soles. It does not apply (it reports ``applicable =
False`` and outputs joint damping) with the CoM height c_z below a bound, any other part
of the robot on the ground, or the pelvis tilted more than a bound from vertical,
θ = acos(R_zz) with R the pelvis rotation. A NaN or inf in the state is an error.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from hybrid_recovery.control.robot_state import RobotState

NAN_STATE_MESSAGE = "BalanceController: the state has NaN or inf entries (qpos or qvel)"


def all_finite(*arrays: np.ndarray) -> bool:
    """No NaN or inf in any of ``arrays`` (a finite sum first: one pass in the usual case;
    a sum that overflows falls back to the entries)."""
    return all(math.isfinite(a.sum()) or bool(np.isfinite(a).all()) for a in arrays)


def check_state(data: mujoco.MjData) -> None:
    """Raises ValueError (:data:`NAN_STATE_MESSAGE`) on a non-finite qpos or qvel."""
    if not all_finite(data.qpos, data.qvel):
        raise ValueError(NAN_STATE_MESSAGE)


def pelvis_tilt(state: RobotState) -> float:
    """θ = acos(R_zz), the pelvis's z axis from vertical [rad]."""
    return math.acos(min(max(float(state.pelvis_rotation[2, 2]), -1.0), 1.0))


def down_reason(state: RobotState, min_com_height: float, max_tilt: float) -> str:
    """Why the QP does not apply to ``state`` ("" when it does): the CoM below
    ``min_com_height`` [m], a non-foot contact, or the pelvis tilted more than
    ``max_tilt`` [rad]."""
    if state.com[2] < min_com_height:
        return f"CoM height {state.com[2]:.2f} m < {min_com_height:.2f} m"
    if state.non_foot_contact:
        return "non-foot contact with the ground"
    tilt = pelvis_tilt(state)
    if tilt > max_tilt:
        return f"pelvis tilt {np.degrees(tilt):.0f} deg > {np.degrees(max_tilt):.0f} deg"
    return ""
