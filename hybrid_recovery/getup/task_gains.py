"""Gains and weights of the tasks the multi-contact moves share.

:class:`~hybrid_recovery.getup.push_up.PushUp` and
:class:`~hybrid_recovery.getup.to_squat.ToSquat` both put these tasks on
:class:`~hybrid_recovery.getup.contact_qp.ContactQP`, each a weighted PD law toward a
reference:

* posture: q̈°_a = q̈_r + K_p (q_r − q) + K_d (q̇_r − q̇);
* pelvis height: z̈° = z̈_r + K_z (z_r − z) + D_z (ż_r − ż);
* pelvis damping: the pelvis's angular velocity damped;
* landing: a hand, knee or foot not yet on the floor has its lowest point p_z lowered,
  p̈°_z = K_l (0 − p_z) − D_l ṗ_z.
"""

from __future__ import annotations

from dataclasses import dataclass

from hybrid_recovery.checks import NON_NEGATIVE, Range, check_fields


@dataclass(frozen=True)
class ContactTaskGains:
    """Gains and weights of the posture, pelvis and landing tasks (module docstring).

    Attributes:
        kp_posture: K_p [1/s²]. kd_posture: K_d [1/s]. w_posture: task weight.
        kp_height: K_z [1/s²]. kd_height: D_z [1/s]. w_height: task weight.
        kd_pelvis: Pelvis angular velocity damping [1/s]. w_pelvis: its weight.
        kp_landing: K_l [1/s²]. kd_landing: D_l [1/s]. w_landing: weight of the landing
            tasks.
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
        check_config(self)


RANGES: dict[str, Range] = {name: NON_NEGATIVE for name in (
    "kp_posture", "kd_posture", "w_posture", "kp_height", "kd_height", "w_height",
    "kd_pelvis", "w_pelvis", "kp_landing", "kd_landing", "w_landing")}
"""Field of :class:`ContactTaskGains` → its range."""


def check_config(config: ContactTaskGains) -> None:
    """Every number finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: e.g. ``ContactTaskGains.kp_posture must be >= 0, got -1.0``.
    """
    check_fields(config, RANGES)
