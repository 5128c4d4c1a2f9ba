"""The push-up from knee-chest to hands and knees under the multi-contact torque QP.

At the best force distribution this move needs 65 % of the arm limits; joint PD does
not realise that distribution (the arms take more than their share and saturate).
:class:`PushUp` runs it at torque level instead
(:class:`hybrid_recovery.getup.contact_qp.ContactQP`, ``ctrl = τ`` on the torque model,
every physics step) on the hands, knees and toes:

* posture task: q̈°_a = q̈_r + K_p (q_r − q) + K_d (q̇_r − q̇), q_r a smoothstep from the
  joints at the start to the keyframe (clamped to the ranges × ``range_factor``) over
  ``duration``;
* base task: the pelvis height z_r on a smoothstep from its start to ``pelvis_height``,
  z̈° = z̈_r + K_z (z_r − z) + D_z (ż_r − ż), and the pelvis's angular velocity damped;
* forces pulled toward the static-feasibility QP's
  (:func:`hybrid_recovery.getup.feasibility.static_feasibility`) on the same contacts,
  refreshed every ``force_update`` seconds.

A named contact of the set bears load while MuJoCo reports it on the floor
(:func:`hybrid_recovery.getup.contact_map.floor_contacts`). A noisy knee-chest often
rests on one knee, the other a few millimetres up: whenever a hand or knee is off the
floor, a landing task lowers its lowest point p_z, p̈°_z = K_l (0 − p_z) − D_l ṗ_z.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from hybrid_recovery.checks import POSITIVE, Range, check_fields
from hybrid_recovery.control.wbc_qp import Task
from hybrid_recovery.getup.contact_map import floor_contacts
from hybrid_recovery.getup.contact_qp import ContactQP, ContactQpConfig, ContactQpSolution
from hybrid_recovery.getup.contact_tasks import (
    ContactTaskGains,
    landing_task,
    pelvis_tasks,
    posture_task,
)
from hybrid_recovery.getup.feasibility import static_feasibility
from hybrid_recovery.getup.ground_state import read_ground_pose
from hybrid_recovery.getup.keyframes import KEYFRAMES
from hybrid_recovery.getup.smoothstep import smoothstep_profile
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses

HANDS_KNEES_TOES = ("left_hand", "right_hand", "left_knee", "right_knee", "left_toes",
                    "right_toes")
"""The push-up's contact set."""

HANDS_KNEES = HANDS_KNEES_TOES[:4]
"""The contacts that must have landed before the move starts."""

_ALLOWED = {f"{side}_{part}" for side in ("left", "right")
            for part in ("hand", "knee", "shin", "toes", "heel", "foot")}


@dataclass(frozen=True)
class PushUpConfig:
    """Settings of :class:`PushUp`.

    Attributes:
        keyframe: Joint keyframe to reach (:data:`~hybrid_recovery.getup.keyframes.KEYFRAMES`).
        contacts: Named contacts that may bear load.
        duration: Smoothstep duration [s].
        pelvis_height: Pelvis height z at the end [m] (settled hands and knees: 0.50).
        force_update: Period of the reference-force refresh [s].
        range_factor: Keyframe clamped to the joint ranges × this about their middle.
        gains: Gains and weights of the posture, pelvis and landing tasks.
        qp: Settings of the QP.
    """

    keyframe: str = "hands_knees"
    contacts: tuple[str, ...] = HANDS_KNEES_TOES
    duration: float = 3.0
    pelvis_height: float = 0.50
    force_update: float = 0.05
    range_factor: float = 0.9
    gains: ContactTaskGains = field(default_factory=ContactTaskGains)
    qp: ContactQpConfig = field(default_factory=ContactQpConfig)

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {
    "duration": POSITIVE, "pelvis_height": POSITIVE, "force_update": POSITIVE,
    "range_factor": (0.0, False, 1.0)}
"""Field of :class:`PushUpConfig` → its range."""


def check_config(config: PushUpConfig) -> None:
    """The keyframe is known; every number finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: ``unknown keyframe 'squat': ...``, or e.g. ``PushUpConfig.duration
            must be > 0, got 0.0``.
    """
    if config.keyframe not in KEYFRAMES:
        raise ValueError(f"unknown keyframe '{config.keyframe}': use one of "
                         f"{sorted(KEYFRAMES)}")
    check_fields(config, RANGES)


class PushUp:
    """τ for the push-up, one QP per physics step.

    Attributes:
        statuses: Count of each :attr:`ContactQpSolution.status` so far.
        worst_ratio: max_j |τ_j| / τ_max,j over the steps so far.
        last: The last :class:`ContactQpSolution`.
    """

    def __init__(self, config: PushUpConfig | None = None) -> None:
        self.config = config or PushUpConfig()

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Starts the move from ``data``'s state."""
        cfg = self.config
        self.qp = ContactQP(model, cfg.qp)
        self._qadr = joint_addresses(model)[0]
        self._pelvis = model.body(constants.PELVIS_BODY).id
        lo, hi = SafetyLimits.from_model(model).q_ref_bounds(cfg.range_factor)
        self._q0 = data.qpos[self._qadr].copy()
        self._q1 = np.clip(KEYFRAMES[cfg.keyframe], lo, hi)
        self._z0 = float(data.xpos[self._pelvis, 2])
        self._t0 = float(data.time)
        self._next_forces = self._t0
        self._reference: dict[str, np.ndarray] = {}
        self.statuses: dict[str, int] = {}
        self.worst_ratio = 0.0
        self.last: ContactQpSolution | None = None

    def tasks(self, data: mujoco.MjData, missing: tuple[str, ...]) -> list[Task]:
        """The posture, pelvis-height, pelvis-damping and landing tasks of ``data``'s
        time (:mod:`~hybrid_recovery.getup.contact_tasks`), ``missing`` the hands and knees
        off the floor."""
        cfg, gains = self.config, self.config.gains
        profile = smoothstep_profile(float(data.time) - self._t0, cfg.duration)
        tasks = [posture_task(data.qpos[self._qadr], data.qvel[6:], self._q0, self._q1,
                              profile, gains),
                 *pelvis_tasks(self.qp, self._state, self._pelvis,
                               (self._z0, cfg.pelvis_height), profile, gains)]
        if missing:
            tasks.append(landing_task(self.qp, missing, gains))
        return tasks

    def _reference_forces(self, data: mujoco.MjData, active: tuple[str, ...],
                          names: tuple[str, ...]) -> np.ndarray | None:
        """f° per point: the static check's forces on ``active`` (refreshed every
        ``force_update``), a contact's total split evenly where its points differ."""
        if float(data.time) >= self._next_forces or set(self._reference) != set(active):
            self._next_forces = float(data.time) + self.config.force_update
            try:
                check = static_feasibility(self.qp.reader.robot, data.qpos, active)
            except ValueError:
                return None
            if not check.supported:
                return None
            self._reference = dict(check.forces)
        out: list[np.ndarray] = []
        names_arr = np.array(names)
        for name in active:
            count = int((names_arr == name).sum())
            forces = self._reference[name]
            out.extend(forces if len(forces) == count
                       else [forces.sum(axis=0) / max(count, 1)] * count)
        return np.array(out).reshape(-1, 3)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m], motor order, for ``data``'s state."""
        cfg = self.config
        self._state = self.qp.read(data)
        touching = set(floor_contacts(model, data)[0])
        active = tuple(c for c in cfg.contacts if c in touching) or cfg.contacts[:1]
        missing = tuple(c for c in HANDS_KNEES if c in cfg.contacts and c not in touching)
        names = self.qp.points(active).names
        reference = self._reference_forces(data, active, names)
        solution = self.qp.solve(self._state, active, self.tasks(data, missing), reference)
        self.last = solution
        self.statuses[solution.status] = self.statuses.get(solution.status, 0) + 1
        ratio = float(np.max(np.abs(solution.torque) / constants.EFFORT_LIMITS))
        self.worst_ratio = max(self.worst_ratio, ratio)
        return solution.torque


def on_hands_and_knees(model: mujoco.MjModel, data: mujoco.MjData,
                       min_pelvis_height: float = 0.45, min_spine_z: float = -0.1
                       ) -> tuple[bool, str]:
    """Whether a forwarded state is on hands and knees: both hands and both knees on the
    floor and nothing else but shins and feet, chest facing down (its axis within 37° of
    −ẑ), the pelvis at least ``min_pelvis_height`` [m] high and the spine no more than
    asin(−min_spine_z) below horizontal (knee-chest: −20° to −24°).

    Returns:
        (on hands and knees, what was read).
    """
    touching, _ = floor_contacts(model, data)
    pose = read_ground_pose(model, data)
    need = {"left_hand", "right_hand", "left_knee", "right_knee"}
    ok = (need <= set(touching) and set(touching) <= _ALLOWED and pose.chest_z < -0.8
          and pose.pelvis_height >= min_pelvis_height and pose.spine_z >= min_spine_z)
    return ok, (f"touching {list(touching)}, pelvis {pose.pelvis_height:.3f} m, "
                f"spine_z {pose.spine_z:.2f}, chest_z {pose.chest_z:.2f}")
