"""The ``model`` and ``hybrid`` controllers with getting up from the ground.

Both run on the torque-controlled H1-2 (``ctrl = τ``, dt 2 ms) with the evaluation
runner's interface (``name``, ``physics_dt``, ``torque_control``, ``reset``, ``__call__``,
``info``).

* :class:`ModelController` — the model-based half alone: the QP balance controller while
  it applies, and on the ground the contact-state moves to knee-chest, where it stops
  and holds (no model-based rise from the ground was found: the push-up to hands and
  knees saturates the arms, and hands-and-knees → kneeling has no static support).
* :class:`GroundHybridController` — on the ground, the moves to the hand-over state
  (knee-chest), then the learned policy under the capturability supervisor
  (:class:`hybrid_recovery.control.supervisor.HybridSupervisor`), which hands back to the
  QP once the robot stands. If the robot ends up lying still under the policy, the moves
  start again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.supervisor import POLICY, HybridSupervisor
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.getup.ground_state import classify, read_ground_pose
from hybrid_recovery.getup.move_executor import MOVING, GroundMoves, MoveConfig
from hybrid_recovery.getup.moves import NEXT_MOVE

MOVES, SUPERVISOR, QP = "moves", "supervisor", "qp"


@dataclass(frozen=True)
class GetupConfig:
    """When the ground moves take over.

    Attributes:
        moves: Settings of the moves (goal = the hand-over state).
        ground_com_height: Below this CoM height a robot the QP does not apply to is on
            the ground and starts with the moves [m] (kneeling and squatting starts, with
            the CoM near 0.55 m, go to the policy at once).
        relapse_time: Lying this long in a state a move starts from, under the policy,
            starts the moves again [s].
        max_relapses: Most such restarts per episode.
    """

    moves: MoveConfig = field(default_factory=MoveConfig)
    ground_com_height: float = 0.45
    relapse_time: float = 3.0
    max_relapses: int = 2


def _com_height(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    return float(data.subtree_com[model.body("pelvis").id, 2])


def _events(moves: GroundMoves) -> list[tuple[float, str, str]]:
    return [(round(e.time, 3), e.kind, e.message) for e in moves.events]


class GroundHybridController:
    """Ground moves → learned policy → QP (``--controller hybrid``).

    Args:
        policy: ``policy.onnx`` or the directory holding it.
        config: Settings; defaults when None.
    """

    name = "hybrid"
    physics_dt = CONTROL_DT
    torque_control = True

    def __init__(self, policy: str | Path, config: GetupConfig | None = None) -> None:
        path = Path(policy)
        self.config = config or GetupConfig()
        self.supervisor = HybridSupervisor.from_onnx(
            path / "policy.onnx" if path.is_dir() else path)
        self.moves = GroundMoves(self.config.moves)

    @property
    def policy(self):
        """The exported policy (its ``description`` holds the training provenance)."""
        return self.supervisor.policy.policy

    @property
    def phase(self) -> str:
        """What acts now: ``"settle"``, ``"<move>/<keyframe>"``, ``"policy"`` or ``"qp"``."""
        if self.mode == MOVES:
            move = self.moves.move
            if move is None:
                return "settle"
            return f"{move.name}/{move.phases[self.moves.phase].keyframe}"
        return self.supervisor.mode

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.supervisor.reset(model, data)
        self.handovers: list[tuple[float, str]] = []
        self.move_log: list[tuple[float, str, str]] = []
        self.relapses = 0
        self._lying = 0.0
        if self.supervisor.mode == POLICY and _com_height(model, data) < \
                self.config.ground_com_height:
            self._start_moves(model, data)
        else:
            self.mode = SUPERVISOR

    def _start_moves(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.mode = MOVES
        self.moves.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m]."""
        if self.mode == MOVES:
            torque = self.moves(model, data)
            if self.moves.status == MOVING:
                return torque
            self.move_log += _events(self.moves)
            self.handovers.append((round(float(data.time), 3), self.moves.state))
            self.mode = SUPERVISOR
            self.supervisor.reset(model, data)
        torque = self.supervisor(model, data)
        if self.supervisor.mode == POLICY and self.relapses < self.config.max_relapses:
            lying = (_com_height(model, data) < self.config.ground_com_height
                     and classify(read_ground_pose(model, data)) in NEXT_MOVE)
            self._lying = self._lying + model.opt.timestep if lying else 0.0
            if self._lying >= self.config.relapse_time - 1e-9:
                self.relapses += 1
                self._lying = 0.0
                self._start_moves(model, data)
                return self.moves(model, data)
        return torque

    def info(self) -> dict:
        log = self.move_log + (_events(self.moves) if self.mode == MOVES else [])
        return {"final_mode": self.mode if self.mode == MOVES else self.supervisor.mode,
                "handovers": self.handovers, "moves": log, "relapses": self.relapses,
                "switches": [(round(e.time, 3), e.kind, e.message)
                             for e in self.supervisor.events]}


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
                "moves": _events(self.moves) if ground else [],
                "ground_status": self.moves.status if ground else None,
                "ground_state": self.moves.state if ground else None}
