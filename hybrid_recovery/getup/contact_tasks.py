"""The posture, pelvis and landing tasks the multi-contact moves share.

:class:`~hybrid_recovery.getup.push_up.PushUp` and
:class:`~hybrid_recovery.getup.to_squat.ToSquat` put these on
:class:`~hybrid_recovery.getup.contact_qp.ContactQP`, each a weighted PD law
(:class:`ContactTaskGains`) toward a reference that goes
from the move's start (·)₀ to its end (·)₁ along a smoothstep s(t)
(:func:`~hybrid_recovery.getup.smoothstep.smoothstep_profile`):

* posture: q̈°_a = q̈_r + K_p (q_r − q) + K_d (q̇_r − q̇), q_r = q₀ + s (q₁ − q₀);
* pelvis height: z̈° = z̈_r + K_z (z_r − z) + D_z (ż_r − ż) − J̇_z q̇,
  z_r = z₀ + s (z₁ − z₀);
* pelvis damping: ω̇° = −D_ω ω − J̇_ω q̇, the pelvis's angular velocity ω damped;
* landing: a contact not yet on the floor has its lowest points p lowered,
  p̈°_z = K_l (0 − p_z) − D_l ṗ_z − (J̇ q̇)_z.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import mujoco
import numpy as np

from hybrid_recovery.checks import NON_NEGATIVE, Range, check_fields
from hybrid_recovery.control.robot_state import RobotState
from hybrid_recovery.control.wbc_qp import Task
from hybrid_recovery.getup.contact_qp import ContactQP


@dataclass(frozen=True)
class ContactTaskGains:
    """Gains and weights of the posture, pelvis and landing tasks (module docstring).

    Attributes:
        kp_posture: K_p [1/s²]. kd_posture: K_d [1/s]. w_posture: task weight.
        kp_height: K_z [1/s²]. kd_height: D_z [1/s]. w_height: task weight.
        kd_pelvis: D_ω, pelvis angular velocity damping [1/s]. w_pelvis: its weight.
        kp_landing: K_l [1/s²]. kd_landing: D_l [1/s]. w_landing: weight of the landing
            tasks (the to-squat's: :data:`~hybrid_recovery.getup.to_squat.SWING_GAINS`).
    """

    kp_posture: float = 100.0
    kd_posture: float = 20.0
    w_posture: float = 1.0
    kp_height: float = 100.0
    kd_height: float = 20.0
    w_height: float = 10.0
    kd_pelvis: float = 10.0
    w_pelvis: float = 1.0
    kp_landing: float = 400.0
    kd_landing: float = 40.0
    w_landing: float = 100.0

    def __post_init__(self) -> None:
        check_gains(self)


GAIN_RANGES: dict[str, Range] = {f.name: NON_NEGATIVE for f in fields(ContactTaskGains)}
"""Field of :class:`ContactTaskGains` → its range."""


def check_gains(config: ContactTaskGains) -> None:
    """Every number finite and in its range (:data:`GAIN_RANGES`).

    Raises:
        ValueError: e.g. ``ContactTaskGains.kp_posture must be >= 0, got -1.0``.
    """
    check_fields(config, GAIN_RANGES)


Profile = tuple[float, float, float]
"""(s [-], ṡ [1/s], s̈ [1/s²]) of the move's smoothstep now."""


def posture_task(q: np.ndarray, qd: np.ndarray, start: np.ndarray, end: np.ndarray,
                 profile: Profile, gains: ContactTaskGains) -> Task:
    """q̈°_a toward q_r(s) (module docstring).

    Args:
        q: q, shape (27,) [rad], motor order. qd: q̇, shape (27,) [rad/s].
        start: q₀, shape (27,) [rad]. end: q₁, shape (27,) [rad].
        profile: (s, ṡ, s̈) now.
        gains: K_p, K_d and the weight.
    """
    s, rate, curv = profile
    delta = end - start
    selector = np.hstack([np.zeros((27, 6)), np.eye(27)])
    target = (curv * delta + gains.kp_posture * (start + s * delta - q)
              + gains.kd_posture * (rate * delta - qd))
    return Task("posture", selector, target, gains.w_posture)


def pelvis_tasks(qp: ContactQP, state: RobotState, pelvis: int,
                 height: tuple[float, float], profile: Profile, gains: ContactTaskGains
                 ) -> list[Task]:
    """The pelvis-height task toward z_r(s) and the pelvis-damping task (module
    docstring), on the state ``qp`` has read (:meth:`ContactQP.read`).

    Args:
        qp: The move's QP, its reader holding the tick's state.
        state: The tick's state (``qp.read(data)``).
        pelvis: The pelvis body id.
        height: (z₀, z₁) [m].
        profile: (s, ṡ, s̈) now.
        gains: K_z, D_z, D_ω and the weights.

    Returns:
        [pelvis height, pelvis damping].
    """
    s, rate, curv = profile
    z0, z1 = height
    m, d = qp.model, qp.reader.data
    jac, jdot = np.zeros((3, qp.nv)), np.zeros((3, qp.nv))
    mujoco.mj_jacBody(m, d, jac, None, pelvis)
    mujoco.mj_jacDot(m, d, jdot, None, d.xpos[pelvis], pelvis)
    dz = z1 - z0
    z, zd = float(d.xpos[pelvis, 2]), float(jac[2] @ d.qvel)
    target = (curv * dz + gains.kp_height * (z0 + s * dz - z)
              + gains.kd_height * (rate * dz - zd) - float(jdot[2] @ d.qvel))
    damping = -gains.kd_pelvis * state.pelvis_angvel - state.pelvis_bias_acc
    return [Task("pelvis_height", jac[2:3], np.array([target]), gains.w_height),
            Task("pelvis_damping", state.pelvis_jacobian, damping, gains.w_pelvis)]


def landing_task(qp: ContactQP, contacts: tuple[str, ...], gains: ContactTaskGains) -> Task:
    """p̈°_z of the lowest points of ``contacts`` (off the floor) toward the floor
    (module docstring), on the state ``qp`` has read: one row per point."""
    low = qp.points(contacts)
    vz = low.jacobians[:, 2] @ qp.reader.data.qvel
    return Task("landing", low.jacobians[:, 2],
                -gains.kp_landing * low.positions[:, 2] - gains.kd_landing * vz
                - low.bias_acc[:, 2], gains.w_landing)
