"""The QP baseline and the hybrid supervisor as evaluation controllers (``qp``, ``hybrid:PATH``).

Adds what the evaluation's trial runner reads to the plain controller interface:
``name``, ``physics_dt`` (the 2 ms step of the QP), ``torque_control = True`` (build the
model with :func:`hybrid_recovery.control.torque_model.load_torque_model`) and
``info()``, the episode's labels (strategy used, steps, falls, fallbacks, hand-overs).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.config import BalanceConfig, SupervisorConfig
from hybrid_recovery.control.supervisor import HybridSupervisor
from hybrid_recovery.control.torque_model import CONTROL_DT


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
    physics_dt = CONTROL_DT
    torque_control = True

    def __init__(self, policy: str | Path, config: SupervisorConfig | None = None) -> None:
        path = Path(policy)
        self.supervisor = HybridSupervisor.from_onnx(
            path / "policy.onnx" if path.is_dir() else path, config=config)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.supervisor.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        return self.supervisor(model, data)

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
