"""Executes ground moves under joint PD, checks where each ends, re-plans from there.

Every physics step :class:`GroundMoves` returns τ = clip(K_P (q_ref − q) − K_D q̇, ±τ_max)
with the deployment gains (``constants.KP``/``KD``), q_ref on the current phase of the
current move, clamped to the joint ranges × ``range_factor``. When a move's last phase
ends, the ground state is classified: if it is the move's end, the next move starts (or
the goal is reached); if not, the robot re-plans from the state it is in, the roll
alternating sides on a retry, until ``max_moves`` moves have been tried.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.checks import NON_NEGATIVE, POSITIVE, Range, check_fields
from hybrid_recovery.control.diagnostics import Event
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.getup.ground_state import GROUND_STATES, classify, read_ground_pose
from hybrid_recovery.getup.keyframes import KEYFRAMES, mirror
from hybrid_recovery.getup.moves import MOVES, NEXT_MOVE, Move
from hybrid_recovery.getup.smoothstep import smoothstep
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses

MOVING, ARRIVED, STUCK = "moving", "arrived", "stuck"


def base_speed(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """|v_b|, the speed of the floating base (the pelvis) [m/s]."""
    dof = model.jnt_dofadr[0]
    return float(np.linalg.norm(data.qvel[dof:dof + 3]))


@dataclass(frozen=True)
class MoveConfig:
    """Settings of the ground moves.

    Attributes:
        goal: Ground state to reach (the hand-over state).
        range_factor: Targets within the joint ranges scaled by this about their middle.
        max_moves: Moves tried before giving up (``stuck``).
        settle_time: The joints are held at least this long before the first
            classification, so that a robot dropped onto the floor has landed [s].
        rest_speed: ... and after ``settle_time`` until the pelvis is slower than this
            [m/s], so that a falling robot is classified where it comes to rest, not on
            its way down (a squat falling forward passes a state with no move, ``other``,
            on its way to prone or supine).
        max_settle: The first classification comes at the latest this long after the
            start, at rest or not [s].
        time_scale: Every phase's duration and hold are multiplied by this [-] (< 1: the
            same keyframes, faster).
        recheck_time: While stuck in a state with no move, the state is classified again
            this often, with the pelvis at rest [s]; from a state with a move (e.g. toppled
            from ``other`` onto a side) the plan goes on.
        prone_lean: From prone with the torso rolled toward a side by more than this
            (|z| of its left axis, the sine of the roll) the ``to_front`` move, hands
            under the shoulders, runs before the tuck, once per arrival in prone (from a
            torso half on its side the tuck ends in prone again; docs/experiments.md
            §15); inf: never.
    """

    goal: str = "knee_chest"
    range_factor: float = 0.9
    max_moves: int = 8
    settle_time: float = 0.5
    rest_speed: float = 0.2
    max_settle: float = 3.0
    time_scale: float = 1.0
    recheck_time: float = 0.5
    prone_lean: float = float("inf")

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {"range_factor": (0.0, False, 1.0),
                            "max_moves": (1, True, float("inf")), "settle_time": NON_NEGATIVE,
                            "rest_speed": POSITIVE, "max_settle": NON_NEGATIVE,
                            "time_scale": POSITIVE, "recheck_time": POSITIVE,
                            "prone_lean": NON_NEGATIVE}
"""Field of :class:`MoveConfig` → its range."""
INFINITE = ("prone_lean",)
"""Fields of :class:`MoveConfig` where inf means "never"."""


def check_config(config: MoveConfig) -> None:
    """The goal is a ground state some move ends in; every number finite and in its range
    (:data:`RANGES`).

    Raises:
        ValueError: ``unknown goal state ...``, ``no move ends in ...``, or e.g.
            ``MoveConfig.range_factor must be > 0 and <= 1, got 1.2``.
    """
    if config.goal not in GROUND_STATES:
        raise ValueError(f"unknown goal state '{config.goal}': use one of "
                         f"{list(GROUND_STATES)}")
    reachable = sorted({m.end for m in MOVES.values()})
    if config.goal not in reachable:
        raise ValueError(f"no move ends in '{config.goal}': the moves reach {reachable}")
    check_fields(config, RANGES, infinite=INFINITE)


class GroundMoves:
    """Moves from the current ground state to ``config.goal``.

    Attributes:
        status: ``"moving"``, ``"arrived"`` (in the goal state) or ``"stuck"`` (no move
            from this state, or ``max_moves`` used).
        state: The last classified ground state.
        move: The move in progress (None when not moving).
        phase: Index of the phase in progress.
        events: Moves started, arrivals and failures, with their times.
        mirrored: The move in progress runs mirrored (left ↔ right).
    """

    def __init__(self, config: MoveConfig | None = None) -> None:
        self.config = config or MoveConfig()
        self.events: list[Event] = []

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Classifies the start state and plans the first move."""
        limits = SafetyLimits.from_model(model)
        self._lo, self._hi = limits.q_ref_bounds(self.config.range_factor)
        self._qadr, self._dadr = joint_addresses(model)
        self.events = []
        self.moves_tried = 0
        self.move: Move | None = None
        self.mirrored = False
        self._attempts: dict[str, int] = {}
        self._recheck_at = np.inf
        self.q_ref = np.clip(data.qpos[self._qadr], self._lo, self._hi)
        self.state, self.status, self.phase = "", MOVING, 0
        self._settle_until = float(data.time) + self.config.settle_time
        self._settle_latest = float(data.time) + max(self.config.settle_time,
                                                      self.config.max_settle)
        if self.config.settle_time <= 0.0:
            self._plan(model, data)

    def _plan(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        t = float(data.time)
        pose = read_ground_pose(model, data)
        self.state = classify(pose)
        last = self.move.name if self.move is not None else ""
        self.move = None
        if self.state == self.config.goal:
            self.status = ARRIVED
            self.events.append(Event(t, "arrived", f"in {self.state}"))
            return
        name = NEXT_MOVE.get(self.state)
        if (self.state == "prone" and abs(pose.left_z) > self.config.prone_lean
                and last != "to_front"):
            name = "to_front"  # flat on the chest first
        if name is None or self.moves_tried >= self.config.max_moves:
            self.status = STUCK
            self._recheck_at = t + self.config.recheck_time if name is None else np.inf
            why = (f"no move from {self.state}" if name is None
                   else f"{self.moves_tried} moves tried")
            self.events.append(Event(t, "stuck", f"in {self.state}: {why}"))
            return
        attempt = self._attempts.get(name, 0)
        self._attempts[name] = attempt + 1
        self.moves_tried += 1
        self.move, self.mirrored, self.status = MOVES[name], attempt % 2 == 1, MOVING
        self.events.append(Event(t, "move", f"{name} from {self.state}"
                                 + (" (mirrored)" if self.mirrored else "")))
        self._start_phase(0, data)

    def _start_phase(self, index: int, data: mujoco.MjData) -> None:
        assert self.move is not None
        phase = self.move.phases[index]
        target = KEYFRAMES[phase.keyframe]
        self.phase, self._t0 = index, float(data.time)
        self._from = data.qpos[self._qadr].copy()
        self._to = np.clip(mirror(target) if self.mirrored else target, self._lo, self._hi)

    def targets(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """q_ref (27,) [rad] of the current phase (the servo targets on a PD-servo model)."""
        if (self.status == MOVING and self.move is None
                and data.time >= self._settle_until - 1e-9 and self._at_rest(model, data)):
            self._plan(model, data)
        if (self.status == STUCK and data.time >= self._recheck_at - 1e-9
                and base_speed(model, data) < self.config.rest_speed):
            self._recheck_at = float(data.time) + self.config.recheck_time
            state = classify(read_ground_pose(model, data))
            if state != self.state and (state == self.config.goal or state in NEXT_MOVE):
                self.status = MOVING
                self._plan(model, data)
        if self.move is not None:
            phase = self.move.phases[self.phase]
            elapsed, scale = float(data.time) - self._t0, self.config.time_scale
            if elapsed >= (phase.duration + phase.hold) * scale - 1e-9:
                if self.phase + 1 < len(self.move.phases):
                    self._start_phase(self.phase + 1, data)
                else:
                    self._finish(model, data)
            if self.move is not None:
                phase = self.move.phases[self.phase]
                s = smoothstep((float(data.time) - self._t0) / (phase.duration * scale))[0]
                self.q_ref = (1.0 - s) * self._from + s * self._to
        return self.q_ref

    def _at_rest(self, model: mujoco.MjModel, data: mujoco.MjData) -> bool:
        """The pelvis slower than ``rest_speed``, or ``max_settle`` over."""
        return (data.time >= self._settle_latest - 1e-9
                or base_speed(model, data) < self.config.rest_speed)

    @property
    def goal(self) -> np.ndarray:
        """The keyframe (27,) [rad] the current phase's targets move to and hold (clamped
        to the ranges × ``range_factor``); q_ref when no move is in progress."""
        return self._to if self.move is not None else self.q_ref

    @property
    def label(self) -> str:
        """``"settle"`` before a move is planned, else ``"<move>/<keyframe>"`` of the
        current phase (the ``phase`` of a recorded rise)."""
        if self.move is None:
            return "settle"
        return f"{self.move.name}/{self.move.phases[self.phase].keyframe}"

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m]: the PD law on :meth:`targets` (on a torque-controlled model)."""
        q_ref = self.targets(model, data)
        return pd_torque(q_ref, data.qpos[self._qadr], data.qvel[self._dadr])

    def _finish(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        assert self.move is not None
        move = self.move
        reached = classify(read_ground_pose(model, data))
        if reached != move.end:
            self.events.append(Event(float(data.time), "missed",
                                     f"{move.name} ended in {reached}, not {move.end}"))
        self._plan(model, data)
