"""The ``hybrid`` controller: the policy under the capturability supervisor with the QP,
and ground moves where the policy lies still on the ground.

The supervisor (:class:`hybrid_recovery.control.supervisor.HybridSupervisor`) acts first,
on the ground too. If the robot lies still under the policy for
``GetupConfig.relapse_time`` (:func:`hybrid_recovery.getup.relapse.lying_still`), the
contact-state moves bring it to knee-chest and the supervisor takes over again (a relapse).
The moves run only on a model with the project's named collision geoms
(:func:`hybrid_recovery.getup.contact_map.maps_contacts`); why: ``docs/experiments.md`` §9.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.config import SupervisorConfig
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.supervisor import POLICY, HybridSupervisor
from hybrid_recovery.control.torque_model import CONTROL_DT, servo_target, torque_twin
from hybrid_recovery.controllers.protocol import OUTPUT_KINDS, OutputKind
from hybrid_recovery.controllers.qp import balance_info
from hybrid_recovery.getup.contact_map import maps_contacts
from hybrid_recovery.getup.move_executor import MOVING, GroundMoves
from hybrid_recovery.getup.relapse import GetupConfig, com_height, lying_still, move_events

MOVES, SUPERVISOR = "moves", "supervisor"
SERVO_DT = 0.005
"""The physics step of the position form [s], the ``learned`` controller's."""


class Supervised:
    """:class:`HybridSupervisor` (QP + exported policy) in either output kind.

    ``"position"``: on the PD-servo model at the ``learned`` controller's 5 ms, the
    supervisor computes on the model's torque twin
    (:func:`~hybrid_recovery.control.torque_model.torque_twin`) and its torques become
    servo targets (:func:`~hybrid_recovery.control.torque_model.servo_target`); while the
    policy acts alone the targets are the policy's own, so the hybrid is the policy alone
    wherever the QP does not take part. ``"torque"``: the supervisor's τ as it is, on the
    torque model at 2 ms (the robot's feed-forward torque).

    Args:
        policy: ``policy.onnx``.
        config: Supervisor settings; defaults when None.
        output: The output kind.
    """

    def __init__(self, policy: str | Path, config: SupervisorConfig | None = None,
                 output: OutputKind = "position") -> None:
        self.supervisor = HybridSupervisor.from_onnx(policy, config=config)
        self.output = output
        self._twins: dict[int, tuple[mujoco.MjModel, mujoco.MjModel]] = {}

    def _twin(self, model: mujoco.MjModel) -> mujoco.MjModel:
        if self.output == "torque":
            return model
        if id(model) not in self._twins:  # keep the model alive with its twin
            self._twins[id(model)] = (model, torque_twin(model))
        return self._twins[id(model)][1]

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.supervisor.reset(self._twin(model), data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        torque = self.supervisor(self._twin(model), data)
        if self.output == "torque":
            return torque
        if self.supervisor.joint_target is not None:  # the policy alone: its own targets
            return self.supervisor.joint_target
        q, qd = self.supervisor.policy.joints(data)
        return servo_target(torque, q, qd)

    def info(self) -> dict:
        switches = [(round(e.time, 3), e.kind, e.message) for e in self.supervisor.events]
        return {**balance_info(self.supervisor.balance), "switches": switches,
                "final_mode": self.supervisor.mode}


class HybridController:
    """Policy → QP, with ground moves where the policy lies still (``--controller hybrid``).

    Contract: position output (servo targets q_ref) at 5 ms on the PD-servo model, where
    it equals the ``learned`` controller until the QP or the moves act; or, with
    ``output="torque"``, τ at 2 ms on the torque model (the robot runner's form: the QP's
    torques reach the motors as feed-forward torque), with :attr:`joint_target` set
    while τ is the PD law on the policy's or the moves' targets.

    Args:
        policy: ``policy.onnx`` or the directory holding it.
        config: Settings of the ground moves; defaults when None.
        output: The output kind.

    Raises:
        ValueError: an unknown output kind.
    """

    name = "hybrid"

    def __init__(self, policy: str | Path, config: GetupConfig | None = None,
                 output: OutputKind = "position") -> None:
        if output not in OUTPUT_KINDS:
            raise ValueError(f"output must be one of {OUTPUT_KINDS}, got {output!r}")
        path = Path(policy)
        self.output: OutputKind = output
        self.joint_target: np.ndarray | None = None
        self.physics_dt = SERVO_DT if output == "position" else CONTROL_DT
        self.config = config or GetupConfig()
        self.supervised = Supervised(path / "policy.onnx" if path.is_dir() else path,
                                          output=output)
        self.moves = GroundMoves(self.config.moves)

    @property
    def policy(self):
        """The exported policy (its ``description`` holds the training provenance)."""
        return self.supervised.supervisor.policy.policy

    @property
    def phase(self) -> str:
        """What acts now: ``"settle"``, ``"<move>/<keyframe>"``, ``"policy"`` or ``"qp"``."""
        if self.mode == MOVES:
            return self.moves.label
        return self.supervised.supervisor.mode

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.supervised.reset(model, data)
        self.handovers: list[tuple[float, str]] = []
        self.move_log: list[tuple[float, str, str]] = []
        self.relapses = 0
        self._lying = 0.0
        self.moves_apply = maps_contacts(model)
        if (self.moves_apply and not self.config.policy_first
                and self.supervised.supervisor.mode == POLICY
                and com_height(model, data) < self.config.ground_com_height):
            self.mode = MOVES
            self.moves.reset(model, data)
        else:
            self.mode = SUPERVISOR

    def _moves(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """The moves' command in this controller's output kind."""
        targets = self.moves.targets(model, data)
        if self.output == "position":
            return targets
        self.joint_target = targets
        return pd_torque(targets, *self.supervised.supervisor.policy.joints(data))

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Servo targets q_ref (27,) [rad], or τ (27,) [N·m] (:attr:`output`)."""
        self.joint_target = None
        if self.mode == MOVES:
            command = self._moves(model, data)
            if self.moves.status == MOVING:
                return command
            self.move_log += move_events(self.moves)
            self.handovers.append((round(float(data.time), 3), self.moves.state))
            self.mode = SUPERVISOR
            self.supervised.reset(model, data)
        command = self.supervised(model, data)
        if self.output == "torque":
            self.joint_target = self.supervised.supervisor.joint_target
        if (self.moves_apply and self.supervised.supervisor.mode == POLICY
                and self.relapses < self.config.max_relapses):
            still = lying_still(model, data, self.config)
            self._lying = self._lying + model.opt.timestep if still else 0.0
            if self._lying >= self.config.relapse_time - 1e-9:
                self.relapses += 1
                self._lying = 0.0
                self.mode = MOVES
                self.moves.reset(model, data)
                return self._moves(model, data)
        return command

    def info(self) -> dict:
        log = self.move_log + (move_events(self.moves) if self.mode == MOVES else [])
        inner = self.supervised.info()
        return {**inner, "final_mode": MOVES if self.mode == MOVES else inner["final_mode"],
                "handovers": self.handovers, "moves": log, "relapses": self.relapses,
                "moves_apply": self.moves_apply}
