"""The ``model`` controller: the model-based half alone, getting up included.

QP balance while it applies; from a crouch on both feet the QP's rise
(:meth:`~hybrid_recovery.control.balance_controller.BalanceController.rise`); from a kneel
the kneel move to a squat (:class:`~hybrid_recovery.getup.kneel_move.KneelMove`), then the
rise; on the ground the contact-state moves to knee-chest, the push-up to hands and knees on the
multi-contact torque QP, hands and knees → squat
(:class:`~hybrid_recovery.getup.to_squat.ToSquat`), then the rise. Where a stage misses,
it re-plans from the state it left (``docs/experiments.md`` §10, §15).
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.controllers.protocol import OutputKind
from hybrid_recovery.getup.keyframes import KEYFRAMES
from hybrid_recovery.getup.kneel_move import (
    CROUCHED,
    FAILED,
    KneelMove,
    KneelMoveConfig,
    is_kneeling,
)
from hybrid_recovery.getup.move_executor import ARRIVED, STUCK, GroundMoves, MoveConfig
from hybrid_recovery.getup.push_up import PushUp, PushUpConfig, on_hands_and_knees
from hybrid_recovery.getup.relapse import com_height, move_events
from hybrid_recovery.getup.to_squat import ToSquat, ToSquatConfig
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses

MOVES, QP, PUSH_UP, HOLD, KNEEL, TO_SQUAT = ("moves", "qp", "push_up", "hold", "kneel",
                                             "to_squat")

GROUND_MOVES = MoveConfig(time_scale=0.5, prone_lean=0.4)
"""The PD moves to knee-chest at twice their keyframes' pace (knee-chest at 6.4 s from a
supine start instead of 12.3 s), a prone torso rolled more than ~24° toward a side laid
flat before the tuck (``MoveConfig.prone_lean``)."""
GROUND_PUSH_UP = PushUpConfig(duration=2.0)
"""The push-up over 2 s (its default: 3 s)."""
GROUND_TO_SQUAT = ToSquatConfig(time_scale=0.85)
"""Hands and knees → squat over 6.5 s (its stages' own pace: 7.6 s). With the three, the
chain from supine reaches its squat at ~14.3 s and stands by ~16.8 s, inside the paper's
20 s trials (at its own pace it stands at ~25.6 s: ``docs/experiments.md`` §15)."""
GROUND_KNEEL = KneelMoveConfig(bow_time=1.0, bow_settle=0.3, push_up=GROUND_PUSH_UP,
                               push_up_settle=0.3, to_squat=GROUND_TO_SQUAT)
"""The kneel move at the ground chain's pace: the bow over 1 s + 0.3 s, then
:data:`GROUND_PUSH_UP` and :data:`GROUND_TO_SQUAT`; the squat at ~10.1 s instead of 13.6 s,
which leaves a locked rise time for its stance resets inside 20 s."""


class ModelController:
    """QP balance when up; from a crouch on both feet the QP's rise; from a kneel the kneel
    move, then the rise; when down, ground moves to knee-chest, the push-up to hands and
    knees, hands and knees → squat, then the rise (``--controller model``). Where the squat
    is not reached or the rise cannot start, it holds hands and knees; where the moves have
    no move from the state they end in and the QP applies there (a move that ends upright,
    a crouch the rise accepts), the QP takes over.

    Contract: torque output τ (27,) [N·m] at 2 ms on the torque model. A push-up that does
    not end on hands and knees re-plans the moves from the state it left.

    Args:
        config: Settings of the moves; :data:`GROUND_MOVES` when None.
        push_up: Settings of the push-up; :data:`GROUND_PUSH_UP` when None.
        to_squat: Settings of hands and knees → squat; :data:`GROUND_TO_SQUAT` when None.
        kneel: Settings of the kneel move; :data:`GROUND_KNEEL` when None.
        push_up_settle: After the push-up's smoothstep, the QP holds its end this long
            before the hands-and-knees check [s].
        max_push_ups: Push-ups tried per episode; after the last one that misses, the
            moves hold knee-chest (or wherever they end).
        rise_wait: After the kneel move or hands and knees → squat reaches its squat, how
            long the squat is held while the rise cannot start (e.g. a hand still on the
            floor) [s].
    """

    name = "model"
    physics_dt = CONTROL_DT
    output: OutputKind = "torque"
    joint_target: np.ndarray | None = None

    def __init__(self, config: MoveConfig | None = None, push_up: PushUpConfig | None = None,
                 to_squat: ToSquatConfig | None = None, kneel: KneelMoveConfig | None = None,
                 push_up_settle: float = 0.3, max_push_ups: int = 2,
                 rise_wait: float = 1.0) -> None:
        self.balance = BalanceController()
        self.moves = GroundMoves(config or GROUND_MOVES)
        self.push_up = PushUp(push_up or GROUND_PUSH_UP)
        self.push_up_settle, self.max_push_ups = push_up_settle, max_push_ups
        self.kneel_config, self.rise_wait = kneel or GROUND_KNEEL, rise_wait
        self.kneel = KneelMove(self.kneel_config)
        self.to_squat = ToSquat(to_squat or GROUND_TO_SQUAT)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.balance.reset(model, data)
        self.move_log: list[tuple[float, str, str]] = []
        self._moves_ran = False
        lo, hi = SafetyLimits.from_model(model).q_ref_bounds(self.moves.config.range_factor)
        self._hold_target = np.clip(KEYFRAMES[self.push_up.config.keyframe], lo, hi)
        self._qadr, self._dadr = joint_addresses(model)
        self.push_ups: list[dict] = []
        self.on_hands_and_knees = False
        self.kneel = KneelMove(self.kneel_config)
        self.squats: list[dict] = []
        crouched = com_height(model, data) < UPRIGHT_COM_HEIGHT
        if crouched and is_kneeling(model, data):
            self.mode = KNEEL
            self.kneel.reset(model, data)
        elif (crouched and self.balance.rise(model, data)) or self.balance.assess(
                model, data).applicable:
            self.mode = QP
        else:
            self._start_moves(model, data)

    @property
    def phase(self) -> str:
        """What acts now: in the ground moves their :attr:`~GroundMoves.label` (``"settle"``
        or ``"<move>/<keyframe>"``, as the hybrid's), else the mode (``"qp"``, ``"kneel"``,
        ``"push_up"``, ``"to_squat"``, ``"hold"``)."""
        return self.moves.label if self.mode == MOVES else self.mode

    def _start_moves(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The ground moves from ``data``'s state; the earlier moves' events stay in the
        log."""
        if self._moves_ran:
            self.move_log += move_events(self.moves)
        self._moves_ran = True
        self.mode = MOVES
        self.moves.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m]."""
        if self.mode == KNEEL:
            torque = self.kneel(model, data)
            if self.kneel.phase not in (CROUCHED, FAILED):
                return torque
            if self.kneel.phase == CROUCHED and self.balance.rise(model, data):
                self.mode = QP
            elif (self.kneel.phase == CROUCHED
                  and float(data.time) < self.kneel.log[-1][0] + self.rise_wait - 1e-9):
                return torque  # the squat held until the rise can start
            else:
                self._start_moves(model, data)
        if self.mode == QP:
            torque = self.balance(model, data)
            diag = self.balance.diagnostics
            if diag is None or diag.applicable:
                return torque
            self._start_moves(model, data)
        if self.mode == MOVES:
            torque = self.moves(model, data)
            if self.moves.status == STUCK and (self.balance.rise(model, data)
                                               or self.balance.assess(model, data).applicable):
                self.mode = QP  # no move from here, but the QP's model holds (e.g. upright)
                return self.balance(model, data)
            if self.moves.status != ARRIVED or len(self.push_ups) >= self.max_push_ups:
                return torque
            self.mode = PUSH_UP  # settled in knee-chest
            self.push_up.reset(model, data)
            self.push_ups.append({"start": round(float(data.time), 3)})
        if self.mode == PUSH_UP:
            elapsed = float(data.time) - self.push_ups[-1]["start"]
            if elapsed < self.push_up.config.duration + self.push_up_settle - 1e-9:
                return self.push_up(model, data)
            arrived = on_hands_and_knees(model, data)[0]
            self.push_ups[-1].update(hands_and_knees=arrived,
                                     worst_torque_ratio=round(self.push_up.worst_ratio, 3))
            if not arrived:  # re-plan
                self._start_moves(model, data)
                return self.moves(model, data)
            self.mode = TO_SQUAT
            self.to_squat.reset(model, data)
            self.squats.append({"start": round(float(data.time), 3)})
        if self.mode == TO_SQUAT:
            torque = self.to_squat(model, data)
            if not self.to_squat.done:
                return torque
            squat = self.squats[-1]
            squat.setdefault("crouched", round(float(data.time), 3))
            if self.balance.rise(model, data):
                squat["rise"] = True
                self.mode = QP
                return self.balance(model, data)
            if float(data.time) < squat["crouched"] + self.rise_wait - 1e-9:
                return torque  # the squat held until the rise can start
            squat["rise"] = False
            self.mode = HOLD
            self._next_check = float(data.time)
        if float(data.time) >= self._next_check - 1e-9:  # still there? (read every 0.25 s)
            self.on_hands_and_knees = on_hands_and_knees(model, data)[0]
            self._next_check = float(data.time) + 0.25
        return pd_torque(self._hold_target, data.qpos[self._qadr], data.qvel[self._dadr])

    def info(self) -> dict:
        """What it did: the final mode, the kneel move's phases, every ground move's events
        (also those of a chain that stood up) and, on the ground, where the moves ended;
        each push-up's start, whether it ended on hands and knees and its worst torque
        ratio; while holding, whether the robot was on hands and knees at the last check
        (every 0.25 s)."""
        ground = self.mode not in (QP, KNEEL)
        rises = [e for e in self.balance.events if e.kind in ("rise", "risen", "rise_failed")]
        return {"final_mode": self.mode, "qp_went_down": self.balance.went_down,
                "kneel": list(self.kneel.log),
                "rise": [(round(e.time, 3), e.kind, e.message) for e in rises],
                "moves": self.move_log + (move_events(self.moves) if self._moves_ran else []),
                "ground_status": self.moves.status if ground else None,
                "ground_state": self.moves.state if ground else None,
                "push_ups": list(self.push_ups), "squats": list(self.squats),
                "on_hands_and_knees": self.on_hands_and_knees if self.mode == HOLD else None}
