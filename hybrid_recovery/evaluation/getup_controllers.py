"""The ``hybrid`` controller with getting up: the supervised policy, ground moves where it
gives up.

The hybrid supervisor (:class:`hybrid_recovery.evaluation.model_controllers.
HybridEvalController`: the policy, and the QP once the robot stands) acts first, on the
ground too: the policy rises from sitting and supine in about 5 s, the moves take 12 s to
hand over. If the robot lies still on the ground under the policy for
``GetupConfig.relapse_time`` (:func:`hybrid_recovery.getup.controllers.lying_still`),
whatever ground state it is in, the contact-state moves
(:class:`hybrid_recovery.getup.move_executor.GroundMoves`) bring it from that state to the
hand-over state, knee-chest, and the supervisor takes over again (a relapse). With
``GetupConfig.policy_first`` False a robot that starts on the ground (the QP does not
apply, CoM below ``GetupConfig.ground_com_height``) starts with the moves. Everything runs on
the PD-servo model at the ``learned`` controller's step: the moves' joint targets are the
servo targets, so from a standing start this controller is the supervisor exactly. The
moves run only on a model with the collision geoms the named contacts are named after
(:func:`hybrid_recovery.getup.contact_map.maps_contacts`); on another (the manufacturer's
meshes) the supervisor keeps the ground: there the moves reach knee-chest too, but the
policy pauses for over 3 s before some rises, and moves started then hand over after
18 s, too late to rise in a 20-s trial that the policy alone wins (``docs/experiments.md``
§9).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.supervisor import POLICY
from hybrid_recovery.evaluation.model_controllers import HybridEvalController
from hybrid_recovery.getup.contact_map import maps_contacts
from hybrid_recovery.getup.controllers import GetupConfig, com_height, lying_still, move_events
from hybrid_recovery.getup.move_executor import MOVING, GroundMoves

MOVES, SUPERVISOR = "moves", "supervisor"


class GroundHybridController:
    """Policy → QP, with ground moves where the policy lies still (``--controller hybrid``).

    Args:
        policy: ``policy.onnx`` or the directory holding it.
        config: Settings; defaults when None.
    """

    name = "hybrid"

    def __init__(self, policy: str | Path, config: GetupConfig | None = None) -> None:
        self.config = config or GetupConfig()
        self.supervised = HybridEvalController(policy)
        self.physics_dt = self.supervised.physics_dt
        self.torque_control = self.supervised.torque_control
        self.moves = GroundMoves(self.config.moves)

    @property
    def policy(self):
        """The exported policy (its ``description`` holds the training provenance)."""
        return self.supervised.supervisor.policy.policy

    @property
    def phase(self) -> str:
        """What acts now: ``"settle"``, ``"<move>/<keyframe>"``, ``"policy"`` or ``"qp"``."""
        if self.mode == MOVES:
            move = self.moves.move
            if move is None:
                return "settle"
            return f"{move.name}/{move.phases[self.moves.phase].keyframe}"
        return self.supervised.supervisor.mode

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.supervised.reset(model, data)
        self.handovers: list[tuple[float, str]] = []
        self.move_log: list[tuple[float, str, str]] = []
        self.relapses = 0
        self._lying = 0.0
        # on another model than the project's the policy keeps the ground (module doc)
        self.moves_apply = maps_contacts(model)
        if (self.moves_apply and not self.config.policy_first
                and self.supervised.supervisor.mode == POLICY
                and com_height(model, data) < self.config.ground_com_height):
            self.mode = MOVES
            self.moves.reset(model, data)
        else:
            self.mode = SUPERVISOR

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Servo targets q_ref (27,) [rad]."""
        if self.mode == MOVES:
            targets = self.moves.targets(model, data)
            if self.moves.status == MOVING:
                return targets
            self.move_log += move_events(self.moves)
            self.handovers.append((round(float(data.time), 3), self.moves.state))
            self.mode = SUPERVISOR
            self.supervised.reset(model, data)
        ctrl = self.supervised(model, data)
        if (self.moves_apply and self.supervised.supervisor.mode == POLICY
                and self.relapses < self.config.max_relapses):
            still = lying_still(model, data, self.config)
            self._lying = self._lying + model.opt.timestep if still else 0.0
            if self._lying >= self.config.relapse_time - 1e-9:
                self.relapses += 1
                self._lying = 0.0
                self.mode = MOVES
                self.moves.reset(model, data)
                return self.moves.targets(model, data)
        return ctrl

    def info(self) -> dict:
        log = self.move_log + (move_events(self.moves) if self.mode == MOVES else [])
        inner = self.supervised.info()
        return {**inner, "final_mode": MOVES if self.mode == MOVES else inner["final_mode"],
                "handovers": self.handovers, "moves": log, "relapses": self.relapses,
                "moves_apply": self.moves_apply}
