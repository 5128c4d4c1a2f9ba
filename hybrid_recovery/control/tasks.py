"""The least-squares tasks of the whole-body QP, each J q̈ ≈ b in MuJoCo coordinates.

* momentum rate: A q̈ = ḣ_des − Ȧ q̇ with ḣ_des = [m c̈_des; L̇_des] (the capture-point
  law of :mod:`.dcm`);
* pelvis orientation: J_ω q̈ = k_p log(R_des Rᵀ) − k_d ω − J̇_ω q̇, R_des the heading only
  (upright);
* posture: q̈_j = k_p (q* − q) − k_d q̇ on the 27 joints;
* swing foot: J_foot q̈ = [ω̇_des; a_des] − J̇ q̇ with a_des = p̈_d + k_p (p_d − p) +
  k_d (ṗ_d − ṗ) along the swing trajectory and a flat sole at the lift-off heading.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from hybrid_recovery.control.config import QpConfig
from hybrid_recovery.control.dcm import DcmCommand
from hybrid_recovery.control.robot_state import FootState, RobotState
from hybrid_recovery.control.wbc_qp import Task
from hybrid_recovery.robot import constants


def momentum_tasks(state: RobotState, cmd: DcmCommand, cfg: QpConfig) -> list[Task]:
    """Linear and angular centroidal momentum rate tasks (3 rows each)."""
    a, drift = state.cmm, state.cmm_drift
    return [
        Task("linear_momentum", a[:3], state.mass * cmd.com_acc - drift[:3],
             cfg.w_linear_momentum),
        Task("angular_momentum", a[3:], cmd.angular_momentum_rate - drift[3:],
             cfg.w_angular_momentum),
    ]


def pelvis_orientation_task(state: RobotState, heading: np.ndarray, cfg: QpConfig) -> Task:
    """Pelvis angular acceleration toward R_des = heading (3, 3) (3 rows)."""
    err = pin.log3(heading @ state.pelvis_rotation.T)
    target = cfg.pelvis_kp * err - cfg.pelvis_kd * state.pelvis_angvel - state.pelvis_bias_acc
    return Task("pelvis_orientation", state.pelvis_jacobian, target, cfg.w_pelvis_orientation)


def posture_task(state: RobotState, selector: np.ndarray, weights: np.ndarray, cfg: QpConfig,
                 reference: np.ndarray | None = None) -> Task:
    """Joint accelerations toward a posture q_ref (27 rows).

    Args:
        state: The tick's state.
        selector: S = [0 I], shape (27, nv).
        weights: Per-joint weights, shape (27,).
        cfg: Gains.
        reference: q_ref, shape (27,) [rad]; None for the default pose q*.
    """
    joints, rates = state.qpos[7:], state.qvel[6:]
    ref = constants.DEFAULT_JOINT_POS if reference is None else reference
    target = cfg.posture_kp * (ref - joints) - cfg.posture_kd * rates
    return Task("posture", selector, target, weights)


def swing_foot_task(foot: FootState, reference: tuple[np.ndarray, np.ndarray, np.ndarray],
                    heading: np.ndarray, cfg: QpConfig) -> Task:
    """Sole tracking of (p_d, ṗ_d, p̈_d) with a flat sole at ``heading`` (6 rows)."""
    pos, vel, acc = reference
    lin = acc + cfg.swing_kp * (pos - foot.position) + cfg.swing_kd * (vel - foot.velocity[3:])
    ang = cfg.swing_kp * pin.log3(heading @ foot.rotation.T) - cfg.swing_kd * foot.velocity[:3]
    return Task("swing_foot", foot.jacobian, np.concatenate([ang, lin]) - foot.bias_acc,
                cfg.w_swing_foot)
