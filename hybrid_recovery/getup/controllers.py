"""The ``model`` controller: the model-based half alone, getting up included.

Runs on the torque-controlled H1-2 (``ctrl = τ``, dt 2 ms) with the evaluation runner's
interface (``name``, ``physics_dt``, ``torque_control``, ``reset``, ``__call__``,
``info``): the QP balance controller while it applies, and on the ground the
contact-state moves to knee-chest, where it stops and holds (no model-based rise from the
ground was found: the push-up to hands and knees saturates the arms, and hands-and-knees
→ kneeling has no static support). The ``hybrid`` controller's ground part is
:class:`hybrid_recovery.evaluation.getup_controllers.GroundHybridController`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.getup.move_executor import GroundMoves, MoveConfig
from hybrid_recovery.robot import constants

MOVES, QP = "moves", "qp"


@dataclass(frozen=True)
class GetupConfig:
    """When the ground moves take over.

    Attributes:
        moves: Settings of the moves (goal = the hand-over state).
        ground_com_height: Below this CoM height a robot the QP does not apply to is on
            the ground and starts with the moves [m] (kneeling and squatting starts, with
            the CoM near 0.55 m, go to the policy at once).
        relapse_time: Lying still this long without a break under the policy (CoM below
            ``ground_com_height``, every joint slower than ``still_joint_speed``, the base
            slower than ``still_base_speed``) starts the moves again from whatever ground
            state the robot is in [s].
        still_joint_speed: Largest joint speed |q̇_j| of a robot lying still [rad/s] (a
            policy still trying to rise moves some joint at several rad/s; one that has
            given up twitches below ~1 rad/s).
        still_base_speed: Largest pelvis speed |v_b| of a robot lying still [m/s].
        max_relapses: Most such restarts per episode.
    """

    moves: MoveConfig = field(default_factory=MoveConfig)
    ground_com_height: float = 0.45
    relapse_time: float = 1.0
    still_joint_speed: float = 2.0
    still_base_speed: float = 0.2
    max_relapses: int = 2


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
    """QP balance when up, ground moves to knee-chest when down (``--controller model``).

    Args:
        config: Settings of the moves; defaults when None.
    """

    name = "model"
    physics_dt = CONTROL_DT
    torque_control = True

    def __init__(self, config: MoveConfig | None = None) -> None:
        self.balance = BalanceController()
        self.moves = GroundMoves(config)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.balance.reset(model, data)
        self.move_log: list[tuple[float, str, str]] = []
        if self.balance.assess(model, data).applicable:
            self.mode = QP
        else:
            self.mode = MOVES
            self.moves.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m]."""
        if self.mode == QP:
            torque = self.balance(model, data)
            diag = self.balance.diagnostics
            if diag is None or diag.applicable:
                return torque
            self.mode = MOVES
            self.moves.reset(model, data)
        return self.moves(model, data)

    def info(self) -> dict:
        ground = self.mode == MOVES
        return {"final_mode": self.mode, "qp_went_down": self.balance.went_down,
                "moves": move_events(self.moves) if ground else [],
                "ground_status": self.moves.status if ground else None,
                "ground_state": self.moves.state if ground else None}
