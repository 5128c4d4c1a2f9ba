"""The QP baseline and the hybrid supervisor as evaluation controllers (``qp``, ``hybrid:PATH``).

Adds what the evaluation's trial runner reads to the plain controller interface:
``name``, ``physics_dt``, ``torque_control`` and ``info()``, the episode's labels
(strategy used, steps, falls, fallbacks, hand-overs).

* ``qp`` runs on the torque model
  (:func:`hybrid_recovery.control.torque_model.load_torque_model`) at the QP's 2 ms.
* ``hybrid`` runs on the same PD-servo model and step (5 ms) as the evaluation's
  ``learned`` controller: the supervisor computes on the model's torque twin
  (:func:`~hybrid_recovery.control.torque_model.torque_twin`) and its torques become
  servo targets (:func:`~hybrid_recovery.control.torque_model.servo_target`). While the
  policy acts, the targets are the policy's own (exactly, up to round-off), so the hybrid
  is the policy alone wherever the QP does not take part.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.config import BalanceConfig, SupervisorConfig
from hybrid_recovery.control.supervisor import HybridSupervisor
from hybrid_recovery.control.torque_model import CONTROL_DT, servo_target, torque_twin


def _balance_info(balance: BalanceController) -> dict:
    return {"strategy": balance.max_strategy.name.lower(),
            "steps": sum(s.touchdown is not None for s in balance.steps),
            "qp_went_down": balance.went_down,
            "qp_fallbacks": sum(e.kind == "fallback" for e in balance.events)}


class QpEvalController:
    """:class:`BalanceController` for the evaluation runner.

    Args:
        config: Controller settings; defaults when None.
    """

    name = "qp"
    physics_dt = CONTROL_DT
    torque_control = True

    def __init__(self, config: BalanceConfig | None = None) -> None:
        self.controller = BalanceController(config)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.controller.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        return self.controller(model, data)

    def info(self) -> dict:
        return _balance_info(self.controller)


class HybridEvalController:
    """:class:`HybridSupervisor` (QP + exported policy) for the evaluation runner.

    Args:
        policy: ``policy.onnx`` or the directory holding it.
        config: Supervisor settings; defaults when None.
    """

    name = "hybrid"
    physics_dt = 0.005
    """The ``learned`` controller's physics step [s]."""
    torque_control = False

    def __init__(self, policy: str | Path, config: SupervisorConfig | None = None) -> None:
        path = Path(policy)
        self.supervisor = HybridSupervisor.from_onnx(
            path / "policy.onnx" if path.is_dir() else path, config=config)
        self._twins: dict[int, tuple[mujoco.MjModel, mujoco.MjModel]] = {}

    def _twin(self, model: mujoco.MjModel) -> mujoco.MjModel:
        if id(model) not in self._twins:  # keep the model alive with its twin
            self._twins[id(model)] = (model, torque_twin(model))
        return self._twins[id(model)][1]

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.supervisor.reset(self._twin(model), data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        torque = self.supervisor(self._twin(model), data)
        if self.supervisor.joint_target is not None:  # the policy alone: its own targets
            return self.supervisor.joint_target
        q, qd = self.supervisor.policy.joints(data)
        return servo_target(torque, q, qd)

    def info(self) -> dict:
        switches = [(round(e.time, 3), e.kind, e.message) for e in self.supervisor.events]
        return {**_balance_info(self.supervisor.balance), "switches": switches,
                "final_mode": self.supervisor.mode}


def eval_controller(kind: str, arg: str | None = None):
    """``eval_controller("qp")`` or ``eval_controller("hybrid", "PATH")``.

    Raises:
        ValueError: Unknown kind, or ``hybrid`` without a policy path.
    """
    if kind == "qp":
        return QpEvalController()
    if kind == "hybrid":
        if not arg:
            raise ValueError("hybrid controller needs a policy path: hybrid:PATH")
        return HybridEvalController(arg)
    raise ValueError(f"unknown controller kind '{kind}': use qp or hybrid")
