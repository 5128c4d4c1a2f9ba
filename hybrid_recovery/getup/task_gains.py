"""Gains and weights of the tasks the multi-contact moves share.

:class:`~hybrid_recovery.getup.push_up.PushUp` and
:class:`~hybrid_recovery.getup.to_squat.ToSquat` both put the posture, pelvis-height,
pelvis-damping and landing tasks of :mod:`hybrid_recovery.getup.contact_tasks` (each a
weighted PD law toward a reference) on
:class:`~hybrid_recovery.getup.contact_qp.ContactQP`, with these gains.
"""

from __future__ import annotations

from dataclasses import dataclass

from hybrid_recovery.checks import NON_NEGATIVE, Range, check_fields


@dataclass(frozen=True)
class ContactTaskGains:
    """Gains and weights of the posture, pelvis and landing tasks
    (:mod:`~hybrid_recovery.getup.contact_tasks`).

    Attributes:
        kp_posture: K_p [1/s²]. kd_posture: K_d [1/s]. w_posture: task weight.
        kp_height: K_z [1/s²]. kd_height: D_z [1/s]. w_height: task weight.
        kd_pelvis: D_ω, pelvis angular velocity damping [1/s]. w_pelvis: its weight.
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
