"""From a kneel on both knees to a squat: bow to knee-chest, push up, then to the squat.

From the two-knee kneel neither a shift onto one knee nor a lean onto the hands has
static support on the H1-2 (``docs/experiments.md`` §10), so :class:`KneelMove` goes down
first: joint PD on a smoothstep to the knee-chest keyframe (a bow), the push-up to hands
and knees (:class:`~hybrid_recovery.getup.push_up.PushUp`), then
:class:`~hybrid_recovery.getup.to_squat.ToSquat` to a squat on both feet, where the QP's
rise takes over.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from hybrid_recovery.checks import NON_NEGATIVE, POSITIVE, Range, check_fields
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, contact_points_in
from hybrid_recovery.getup.ground_state import read_ground_pose
from hybrid_recovery.getup.keyframes import KNEE_CHEST
from hybrid_recovery.getup.push_up import PushUp, PushUpConfig, on_hands_and_knees
from hybrid_recovery.getup.smoothstep import smoothstep
from hybrid_recovery.getup.to_squat import ToSquat, ToSquatConfig
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses

BOW, PUSH_UP, TO_SQUAT, CROUCHED, FAILED = "bow", "push_up", "to_squat", "crouched", "failed"
"""The phases of :class:`KneelMove`: ``crouched`` once the squat is reached, ``failed``
when the push-up did not end on hands and knees."""


@dataclass(frozen=True)
class KneelMoveConfig:
    """Settings of :class:`KneelMove`.

    Attributes:
        bow_time: Smoothstep of the joints to the knee-chest keyframe [s].
        bow_settle: Knee-chest held under joint PD after the smoothstep [s].
        push_up_settle: The push-up's end held on its QP before the check [s].
        range_factor: Keyframes clamped to the joint ranges × this about their middle.
        push_up: Settings of the push-up.
        to_squat: Settings of hands and knees → squat.
    """

    bow_time: float = 2.0
    bow_settle: float = 0.5
    push_up_settle: float = 0.5
    range_factor: float = 0.9
    push_up: PushUpConfig = field(default_factory=PushUpConfig)
    to_squat: ToSquatConfig = field(default_factory=ToSquatConfig)

    def __post_init__(self) -> None:
        check_fields(self, RANGES)


RANGES: dict[str, Range] = {"bow_time": POSITIVE, "bow_settle": NON_NEGATIVE,
                            "push_up_settle": NON_NEGATIVE, "range_factor": (0.0, False, 1.0)}
"""Field of :class:`KneelMoveConfig` → its range."""


def is_kneeling(model: mujoco.MjModel, data: mujoco.MjData, max_knee_height: float = 0.2,
                min_spine_z: float = 0.5) -> bool:
    """Whether a forwarded state kneels: both knee balls within ``max_knee_height`` [m] of
    the floor (a kneeling start dropped onto the floor has a knee up to 0.16 m above it;
    a squat's knees are 0.27 m up or more), the spine within acos(min_spine_z) of
    vertical, no seat body (pelvis, hip links) on the floor."""
    for name in ("left_knee", "right_knee"):
        low = contact_points_in(model, data, FLOOR_CONTACTS[name])
        if float(low[:, 2].min()) > max_knee_height:
            return False
    pose = read_ground_pose(model, data)
    seat = {"pelvis", "left_hip_pitch_link", "right_hip_pitch_link"}
    return pose.spine_z >= min_spine_z and not (pose.touching & seat)


class KneelMove:
    """τ (27,) [N·m] from a kneel to a squat (module docstring), on the torque model.

    Attributes:
        phase: One of :data:`BOW`, :data:`PUSH_UP`, :data:`TO_SQUAT`, :data:`CROUCHED`,
            :data:`FAILED`.
        log: (time [s], event) of each phase's start and the push-up's check.
    """

    def __init__(self, config: KneelMoveConfig | None = None) -> None:
        self.config = config or KneelMoveConfig()
        self.push_up = PushUp(self.config.push_up)
        self.to_squat = ToSquat(self.config.to_squat)
        self.phase = BOW
        self.log: list[tuple[float, str]] = []

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Starts the bow from ``data``'s state."""
        self._qadr, self._dadr = joint_addresses(model)
        lo, hi = SafetyLimits.from_model(model).q_ref_bounds(self.config.range_factor)
        self._q0 = np.clip(data.qpos[self._qadr], lo, hi)
        self._q1 = np.clip(KNEE_CHEST, lo, hi)
        self._t0 = float(data.time)
        self.phase = BOW
        self.log = [(round(self._t0, 3), BOW)]

    def _start(self, phase: str, data: mujoco.MjData) -> None:
        self.phase, self._t0 = phase, float(data.time)
        self.log.append((round(self._t0, 3), phase))

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m], motor order; once crouched, the squat is held (the caller starts
        the rise); once failed, the push-up's last command."""
        cfg, elapsed = self.config, float(data.time) - self._t0
        if self.phase == BOW and elapsed >= cfg.bow_time + cfg.bow_settle - 1e-9:
            self._start(PUSH_UP, data)
            self.push_up.reset(model, data)
        elif (self.phase == PUSH_UP
              and elapsed >= self.push_up.config.duration + cfg.push_up_settle - 1e-9):
            arrived, _ = on_hands_and_knees(model, data)
            self._start(TO_SQUAT if arrived else FAILED, data)
            if arrived:
                self.to_squat.reset(model, data)
        elif self.phase == TO_SQUAT and self.to_squat.done:
            self._start(CROUCHED, data)
        if self.phase == BOW:
            s = smoothstep(elapsed / cfg.bow_time)[0]
            q_ref = self._q0 + s * (self._q1 - self._q0)
            return pd_torque(q_ref, data.qpos[self._qadr], data.qvel[self._dadr])
        if self.phase in (PUSH_UP, FAILED):
            return self.push_up(model, data)
        return self.to_squat(model, data)
