"""The ``model`` controller: the model-based half alone, getting up included.

Runs on the torque-controlled H1-2 (``ctrl = τ``, dt 2 ms) with the evaluation runner's
interface (``name``, ``physics_dt``, ``torque_control``, ``reset``, ``__call__``,
``info``): the QP balance controller while it applies; on the ground the contact-state
moves to knee-chest, the push-up to hands and knees on the multi-contact torque QP
(:class:`hybrid_recovery.getup.push_up.PushUp`), then joint PD holding the
hands-and-knees keyframe (statically balanced, worst torque ratio 0.05), where it stops:
hands-and-knees → kneeling has no static support and no dynamic transition was found,
so there is no model-based rise from the ground. A push-up that does not end on hands
and knees re-plans the moves from the state it left. The ``hybrid`` controller's ground
part is :class:`hybrid_recovery.evaluation.getup_controllers.GroundHybridController`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from hybrid_recovery.checks import NON_NEGATIVE, POSITIVE, Range, check_fields
from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.getup.keyframes import KEYFRAMES
from hybrid_recovery.getup.move_executor import ARRIVED, GroundMoves, MoveConfig
from hybrid_recovery.getup.push_up import PushUp, PushUpConfig, on_hands_and_knees
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses

MOVES, QP, PUSH_UP, HOLD = "moves", "qp", "push_up", "hold"


@dataclass(frozen=True)
class GetupConfig:
    """When the ground moves take over.

    Attributes:
        moves: Settings of the moves (goal = the hand-over state).
        policy_first: On the ground the policy acts first and the moves only once it lies
            still (a relapse, below). False: a robot that starts on the ground starts with
            the moves, for a policy that does not rise from the ground itself.
        ground_com_height: Below this CoM height a robot the QP does not apply to is on
            the ground [m] (kneeling and squatting starts, with the CoM near 0.55 m, are
            not).
        relapse_time: Lying still this long without a break under the policy (CoM below
            ``ground_com_height``, every joint slower than ``still_joint_speed``, the base
            slower than ``still_base_speed``) starts the moves again from whatever ground
            state the robot is in [s]. 3 s: a policy that rises pauses for over 1 s
            after some pushes on the manufacturer's model and rises later, which moves
            started after 1 s cut short (``docs/experiments.md`` §9).
        still_joint_speed: Largest joint speed |q̇_j| of a robot lying still [rad/s] (a
            policy still trying to rise moves some joint at several rad/s; one that has
            given up twitches below ~1 rad/s).
        still_base_speed: Largest pelvis speed |v_b| of a robot lying still [m/s].
        max_relapses: Most such starts of the moves under the policy per episode.
    """

    moves: MoveConfig = field(default_factory=MoveConfig)
    policy_first: bool = True
    ground_com_height: float = 0.45
    relapse_time: float = 3.0
    still_joint_speed: float = 2.0
    still_base_speed: float = 0.2
    max_relapses: int = 2

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {"ground_com_height": POSITIVE, "relapse_time": NON_NEGATIVE,
                            "still_joint_speed": POSITIVE, "still_base_speed": POSITIVE,
                            "max_relapses": NON_NEGATIVE}
"""Field of :class:`GetupConfig` → its range."""


def check_config(config: GetupConfig) -> None:
    """Every number of ``config`` finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: e.g. ``GetupConfig.relapse_time must be >= 0, got -1.0``.
    """
    check_fields(config, RANGES)


def com_height(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """CoM height h_c of the robot (the pelvis subtree) [m]."""
    return float(data.subtree_com[model.body("pelvis").id, 2])


def lying_still(model: mujoco.MjModel, data: mujoco.MjData, config: GetupConfig) -> bool:
    """Whether the robot lies still on the ground: h_c < ``ground_com_height``,
    max_j |q̇_j| < ``still_joint_speed`` over the 27 actuated joints and the pelvis speed
    |v_b| < ``still_base_speed``."""
    if com_height(model, data) >= config.ground_com_height:
        return False
    joints = data.qvel[model.jnt_dofadr[1:1 + constants.NUM_JOINTS]]
    base = data.qvel[model.jnt_dofadr[0]:model.jnt_dofadr[0] + 3]
    return bool(np.abs(joints).max() < config.still_joint_speed
                and np.linalg.norm(base) < config.still_base_speed)


def move_events(moves: GroundMoves) -> list[tuple[float, str, str]]:
    """The moves' events as (time [s], kind, message) rows."""
    return [(round(e.time, 3), e.kind, e.message) for e in moves.events]


class ModelController:
    """QP balance when up; when down, ground moves to knee-chest, the push-up to hands and
    knees, then holding there (``--controller model``).

    Args:
        config: Settings of the moves; defaults when None.
        push_up: Settings of the push-up; defaults when None.
        push_up_settle: After the push-up's smoothstep, the QP holds its end this long
            before the hands-and-knees check [s].
        max_push_ups: Push-ups tried per episode; after the last one that misses, the
            moves hold knee-chest (or wherever they end).
    """

    name = "model"
    physics_dt = CONTROL_DT
    torque_control = True

    def __init__(self, config: MoveConfig | None = None, push_up: PushUpConfig | None = None,
                 push_up_settle: float = 0.5, max_push_ups: int = 2) -> None:
        self.balance = BalanceController()
        self.moves = GroundMoves(config)
        self.push_up = PushUp(push_up)
        self.push_up_settle, self.max_push_ups = push_up_settle, max_push_ups

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.balance.reset(model, data)
        self.move_log: list[tuple[float, str, str]] = []
        lo, hi = SafetyLimits.from_model(model).q_ref_bounds(self.moves.config.range_factor)
        self._hold_target = np.clip(KEYFRAMES[self.push_up.config.keyframe], lo, hi)
        self._qadr, self._dadr = joint_addresses(model)
        self.push_ups: list[dict] = []
        self.on_hands_and_knees = False
        if self.balance.assess(model, data).applicable:
            self.mode = QP
        else:
            self._start_moves(model, data)

    def _start_moves(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.mode = MOVES
        self.moves.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m]."""
        if self.mode == QP:
            torque = self.balance(model, data)
            diag = self.balance.diagnostics
            if diag is None or diag.applicable:
                return torque
            self._start_moves(model, data)
        if self.mode == MOVES:
            torque = self.moves(model, data)
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
            if not arrived:  # re-plan; the earlier moves' events stay in the log
                self.move_log += move_events(self.moves)
                self._start_moves(model, data)
                return self.moves(model, data)
            self.mode = HOLD
            self._next_check = float(data.time)
        if float(data.time) >= self._next_check - 1e-9:  # still there? (read every 0.25 s)
            self.on_hands_and_knees = on_hands_and_knees(model, data)[0]
            self._next_check = float(data.time) + 0.25
        return pd_torque(self._hold_target, data.qpos[self._qadr], data.qvel[self._dadr])

    def info(self) -> dict:
        """What it did: the final mode, the moves' events and end, each push-up's start,
        whether it ended on hands and knees and its worst torque ratio; while holding,
        whether the robot was on hands and knees at the last check (every 0.25 s)."""
        ground = self.mode != QP
        return {"final_mode": self.mode, "qp_went_down": self.balance.went_down,
                "moves": self.move_log + move_events(self.moves) if ground else [],
                "ground_status": self.moves.status if ground else None,
                "ground_state": self.moves.state if ground else None,
                "push_ups": list(self.push_ups),
                "on_hands_and_knees": self.on_hands_and_knees if self.mode == HOLD else None}
