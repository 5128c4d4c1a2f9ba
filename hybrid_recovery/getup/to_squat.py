"""From hands and knees to a squat on both feet, under the multi-contact torque QP.

The contact sequence hands and knees → the left foot flat between the hands (hands, left
foot, right knee and toes) → hands and feet ("bear") → the CoM carried back over the feet
→ a squat (both feet flat) has statically feasible keyframes (:data:`TO_SQUAT_KEYFRAMES`,
solved by the whole-body contact IK with the CoM over their support); between them a leg
swings with the hands bearing load. :class:`ToSquat` runs the stages of
:data:`TO_SQUAT_STAGES` on :class:`~hybrid_recovery.getup.contact_qp.ContactQP`
(``ctrl = τ`` every physics step), with the tasks

* posture: q̈°_a = q̈_r + K_p (q_r − q) + K_d (q̇_r − q̇), q_r a smoothstep from the joints
  at the stage start to the stage's keyframe;
* CoM: c̈°_xy = c̈_r + K_c (c_r − c) + D_c (ċ_r − ċ), c_r a smoothstep from the CoM at the
  stage start into the polygon of the stage's support points;
* pelvis height on a smoothstep to the keyframe's, the pelvis's angular velocity damped;
* landing: a contact the stage lands is lowered once the smoothstep passes
  ``land_after``, p̈°_z = −K_l p_z − D_l ṗ_z.

A stage's contacts bear load while MuJoCo reports them on the floor
(:func:`~hybrid_recovery.getup.contact_map.floor_contacts`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from hybrid_recovery.checks import NON_NEGATIVE, POSITIVE, Range, check_fields
from hybrid_recovery.control.wbc_qp import Task
from hybrid_recovery.getup.contact_ik import CONTACT_KEYFRAMES, ContactIk, ContactKeyframe
from hybrid_recovery.getup.contact_map import floor_contacts
from hybrid_recovery.getup.contact_qp import ContactQP, ContactQpConfig, ContactQpSolution
from hybrid_recovery.getup.contact_tasks import (
    ContactTaskGains,
    Profile,
    landing_task,
    pelvis_tasks,
    posture_task,
)
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, contact_points_in
from hybrid_recovery.getup.keyframes import HANDS_KNEES
from hybrid_recovery.getup.smoothstep import smoothstep_profile
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import joint_addresses

_KNEES = ("left_knee", "right_knee")
_TOES = ("left_toes", "right_toes")
_FEET = ("left_foot", "right_foot")


def _posture(left: tuple[float, ...], right: tuple[float, ...], shoulder: float,
             elbow: float) -> np.ndarray:
    """Joints (27,) [rad]: the legs' six joints each, waist 0, both arms alike."""
    arm = (shoulder, 0.2, 0.0, elbow, 0.0, 0.0, 0.0)
    return np.array([*left, *right, 0.0, *arm, arm[0], -arm[1], *arm[2:]])


def _pitch(angle: float) -> tuple[float, float, float, float]:
    return (float(np.cos(angle / 2)), 0.0, float(np.sin(angle / 2)), 0.0)


_HANDS_KNEES_RIGHT_LEG = tuple(HANDS_KNEES[6:12])
_CROUCH_LEG = (0.0, -1.4, 0.0, 1.4, -0.3, 0.0)
_HANDS = ("left_hand", "right_hand")
_RIGHT_KNEE = (*_HANDS, "right_knee", "right_toes")
_LEFT_FOOT = (*_HANDS, "left_foot", "right_knee", "right_toes")
_BEAR = (*_HANDS, *_FEET)
_HANDS_AND_KNEES = (*_HANDS, *_KNEES, *_TOES)


def _on_hands(left: tuple[float, ...], right: tuple[float, ...]) -> np.ndarray:
    """The hands-and-knees arms and waist with these legs, (27,) [rad]."""
    q = HANDS_KNEES.copy()
    q[:6], q[6:12] = left, right
    return q


TO_SQUAT_KEYFRAMES: dict[str, tuple[ContactKeyframe, tuple[str, ...]]] = {
    "hands_knees": (CONTACT_KEYFRAMES["hands_knees"], ()),
    "left_foot": (ContactKeyframe(_on_hands((0.0, -2.4, 0.0, 1.9, -0.5, 0.0),
                                            _HANDS_KNEES_RIGHT_LEG), _pitch(1.0), _LEFT_FOOT),
                  _LEFT_FOOT),
    "bear": (ContactKeyframe(_on_hands((0.0, -2.3, 0.0, 1.7, -0.5, 0.0),
                                       (0.0, -2.3, 0.0, 1.7, -0.5, 0.0)), _pitch(1.1), _BEAR),
             _BEAR),
    "bear_back": (ContactKeyframe(_on_hands((0.0, -2.0, 0.0, 1.9, -0.6, 0.0),
                                            (0.0, -2.0, 0.0, 1.9, -0.6, 0.0)), _pitch(0.7),
                                  _BEAR), _FEET),
    "squat": (ContactKeyframe(_posture(_CROUCH_LEG, _CROUCH_LEG, -0.8, 0.3), _pitch(0.3), _FEET),
              _FEET),
}
"""Keyframe name → (contact keyframe seed for the IK, contacts the CoM is placed over;
none: free): hands and knees; the left foot flat between the hands; on hands and feet;
the same with the CoM over the feet; a squat on both feet (a shallow one, knees 1.4 rad:
the ankles' dorsiflexion range, 0.9 × 0.9 rad, keeps a deep squat's soles from lying
flat)."""


@dataclass(frozen=True)
class SquatStage:
    """One stage of the move.

    Attributes:
        name: For the log.
        keyframe: Keyframe of :data:`TO_SQUAT_KEYFRAMES` the joints and pelvis height go to.
        contacts: Contacts that may bear load.
        support: Contacts the CoM is carried over (empty: no CoM task).
        lands: Contacts lowered to the floor after ``land_after`` of the stage.
        duration: Smoothstep duration [s].
        land_after: Fraction of the stage after which its ``lands`` are lowered [-].
    """

    name: str
    keyframe: str
    contacts: tuple[str, ...]
    support: tuple[str, ...]
    lands: tuple[str, ...]
    duration: float
    land_after: float = 0.6


TO_SQUAT_STAGES: tuple[SquatStage, ...] = (
    SquatStage("hands_knees", "hands_knees", _HANDS_AND_KNEES, _RIGHT_KNEE, _HANDS, 0.8),
    SquatStage("swing_left", "left_foot", _RIGHT_KNEE, _RIGHT_KNEE, ("left_foot",), 1.5),
    SquatStage("left_foot", "left_foot", _LEFT_FOOT, (*_HANDS, "left_foot"), ("left_foot",),
               0.8),
    SquatStage("swing_right", "bear", (*_HANDS, "left_foot"), (*_HANDS, "left_foot"),
               ("right_foot",), 1.5),
    SquatStage("bear", "bear_back", _BEAR, _FEET, ("right_foot",), 1.5),
    SquatStage("squat", "squat", _FEET, _FEET, (), 1.5),
)
"""hands and knees → left foot forward → right foot forward → CoM over the feet → squat."""


SWING_GAINS = ContactTaskGains(w_landing=1000.0)
"""The to-squat's task gains: the landing task at 10× the pelvis height's weight and
1000× the posture's, so that a swung foot comes down where the posture's keyframe,
planned for other hand and foot places, would hold it in the air (the push-up keeps
the default 100; why: ``docs/experiments.md`` §15)."""


@dataclass(frozen=True)
class ToSquatConfig:
    """Settings of :class:`ToSquat`.

    Attributes:
        kp_com: K_c [1/s²]. kd_com: D_c [1/s]. w_com: task weight.
        support_depth: c_r lies this fraction of the way from the support polygon's
            point nearest the CoM to the middle of the support [-].
        range_factor: Keyframes solved within the joint ranges × this about their middle.
        time_scale: Every stage's duration is multiplied by this [-] (< 1: the same
            keyframes, faster).
        gains: Gains and weights of the posture, pelvis and landing tasks (:data:`SWING_GAINS`).
        qp: Settings of the QP.
    """

    kp_com: float = 100.0
    kd_com: float = 20.0
    w_com: float = 1000.0
    support_depth: float = 0.8
    range_factor: float = 0.9
    time_scale: float = 1.0
    gains: ContactTaskGains = SWING_GAINS
    qp: ContactQpConfig = field(default_factory=ContactQpConfig)

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {
    "kp_com": NON_NEGATIVE, "kd_com": NON_NEGATIVE, "w_com": NON_NEGATIVE,
    "support_depth": (0.0, True, 1.0), "range_factor": (0.0, False, 1.0),
    "time_scale": POSITIVE}
"""Field of :class:`ToSquatConfig` → its range."""


def check_config(config: ToSquatConfig) -> None:
    """Every number finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: e.g. ``ToSquatConfig.support_depth must be >= 0 and <= 1, got 2.0``.
    """
    check_fields(config, RANGES)


_PLANS: dict[tuple[int, float], dict[str, np.ndarray]] = {}


def plan_keyframes(model: mujoco.MjModel, range_factor: float = 0.9
                   ) -> dict[str, np.ndarray]:
    """The keyframes of :data:`TO_SQUAT_KEYFRAMES` by the contact IK, CoM over their
    support: name → qpos (nq,), cached per model."""
    key = (id(model), range_factor)
    if key not in _PLANS:
        ik = ContactIk(model, range_factor)
        _PLANS[key] = {name: ik.solve(seed, com_over=over).qpos
                       for name, (seed, over) in TO_SQUAT_KEYFRAMES.items()}
    return _PLANS[key]


def closest_in_polygon(points: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The point of the convex hull of ``points`` (k, 2) nearest to ``p`` (2,) [m]."""
    pts = np.asarray(points, float).reshape(-1, 2)
    p = np.asarray(p, float)
    if len(pts) >= 3:
        try:
            hull = ConvexHull(pts)
        except QhullError:  # collinear: the segment's end points are among them
            hull = None
        if hull is not None:
            if np.all(hull.equations[:, :2] @ p + hull.equations[:, 2] <= 1e-12):
                return p.copy()
            pts = pts[hull.vertices]
    if len(pts) == 1:
        return pts[0].copy()
    best, best_d = pts[0].copy(), np.inf
    for a, b in zip(pts, np.roll(pts, -1, axis=0), strict=True):
        ab = b - a
        t = 0.0 if ab @ ab < 1e-12 else float(np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0))
        c = a + t * ab
        if (d := float(np.linalg.norm(p - c))) < best_d:
            best, best_d = c, d
    return best


class ToSquat:
    """τ for hands and knees → squat, one QP per physics step (module docstring).

    Attributes:
        stage: Index into :data:`TO_SQUAT_STAGES` of the stage under way
            (``len(TO_SQUAT_STAGES)`` once done).
        log: (time [s], stage name) of each stage's start.
        statuses: Count of each :attr:`ContactQpSolution.status` so far.
        worst_ratio: max_j |τ_j| / τ_max,j over the steps so far.
    """

    def __init__(self, config: ToSquatConfig | None = None,
                 stages: tuple[SquatStage, ...] = TO_SQUAT_STAGES) -> None:
        self.config = config or ToSquatConfig()
        self.stages = stages

    @property
    def done(self) -> bool:
        """Every stage has run."""
        return self.stage >= len(self.stages)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Starts the move from ``data``'s state (on hands and knees)."""
        self.qp = ContactQP(model, self.config.qp)
        self._qadr = joint_addresses(model)[0]
        self._pelvis = model.body(constants.PELVIS_BODY).id
        self._keyframes = plan_keyframes(model, self.config.range_factor)
        self.log: list[tuple[float, str]] = []
        self.statuses: dict[str, int] = {}
        self.worst_ratio = 0.0
        self.last: ContactQpSolution | None = None
        self.stage = -1
        self._state = self.qp.read(data)
        self._next_stage(data)

    def _next_stage(self, data: mujoco.MjData) -> None:
        self.stage += 1
        if self.done:
            return
        stage = self.stages[self.stage]
        target = self._keyframes[stage.keyframe]
        self._t0 = float(data.time)
        self._q0, self._q1 = data.qpos[self._qadr].copy(), target[self._qadr]
        self._z0, self._z1 = float(data.xpos[self._pelvis, 2]), float(target[2])
        self._c0 = self._state.com[:2].copy()
        self._c1 = self._com_target() if stage.support else self._c0
        self.log.append((round(self._t0, 3), stage.name))

    @property
    def goal(self) -> np.ndarray:
        """q_g (27,) [rad], motor order: the joints of the keyframe the stage under way
        moves to (the last stage's once done)."""
        return self._q1.copy()

    def _current(self) -> SquatStage:
        """The stage under way; once done, the last."""
        return self.stages[min(self.stage, len(self.stages) - 1)]

    def _com_target(self) -> np.ndarray:
        """c_r at the stage's end: the CoM at the stage's start moved into the polygon
        of the support points, ``support_depth`` of the way from its edge to the middle
        of the support contacts (the mean of each contact's centre) [m], shape (2,)."""
        stage = self.stages[self.stage]
        points = self.qp.points(stage.support)
        xy = points.positions[:, :2]
        middle = np.mean([self._centre(c) for c in dict.fromkeys(points.names)], axis=0)
        edge = closest_in_polygon(xy, self._c0)
        return edge + self.config.support_depth * (middle - edge)

    def _centre(self, name: str) -> np.ndarray:
        """The mean of all of a contact's points, in the world (x, y) [m], shape (2,): a
        sole's centre also while only its toes bear load (a squat's heels lift ~1 cm), so
        that the squat ends with the CoM over the middle of the feet, where the QP's rise
        can hold its capture point (with the load-bearing points' mean, 6 cm ahead of
        it: ``docs/experiments.md`` §15)."""
        world = contact_points_in(self.qp.model, self.qp.reader.data, FLOOR_CONTACTS[name])
        return world[:, :2].mean(axis=0)

    def _com_task(self, profile: Profile) -> Task:
        """c̈°_xy toward c_r(s) (module docstring), ``profile`` (s, ṡ, s̈) now."""
        cfg, state = self.config, self._state
        s, rate, curv = profile
        dc = self._c1 - self._c0
        com_jac = state.cmm[:2] / state.mass
        com_acc = (curv * dc + cfg.kp_com * (self._c0 + s * dc - state.com[:2])
                   + cfg.kd_com * (rate * dc - state.com_vel[:2])
                   - state.cmm_drift[:2] / state.mass)
        return Task("com", com_jac, com_acc, cfg.w_com)

    def tasks(self, data: mujoco.MjData, touching: set[str]) -> list[Task]:
        """The stage's tasks at ``data``'s time (module docstring)."""
        gains, stage = self.config.gains, self._current()
        profile = smoothstep_profile(float(data.time) - self._t0,
                                     stage.duration * self.config.time_scale)
        tasks = [posture_task(data.qpos[self._qadr], data.qvel[6:], self._q0, self._q1,
                              profile, gains)]
        if stage.support:
            tasks.append(self._com_task(profile))
        tasks += pelvis_tasks(self.qp, self._state, self._pelvis, (self._z0, self._z1),
                              profile, gains)
        landing = tuple(c for c in stage.lands if c not in touching)
        if landing and profile[0] >= stage.land_after:  # s past the stage's land_after
            tasks.append(landing_task(self.qp, landing, gains))
        return tasks

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m], motor order, for ``data``'s state; once done, the last stage's
        end is held."""
        self._state = self.qp.read(data)
        if not self.done and float(data.time) >= (
                self._t0 + self.stages[self.stage].duration * self.config.time_scale):
            self._next_stage(data)
        stage = self._current()
        touching = set(floor_contacts(model, data)[0])
        active = tuple(c for c in stage.contacts if c in touching) or stage.contacts[:1]
        solution = self.qp.solve(self._state, active, self.tasks(data, touching))
        self.last = solution
        self.statuses[solution.status] = self.statuses.get(solution.status, 0) + 1
        ratio = float(np.max(np.abs(solution.torque) / constants.EFFORT_LIMITS))
        self.worst_ratio = max(self.worst_ratio, ratio)
        return solution.torque
