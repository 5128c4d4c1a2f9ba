"""The ``qp`` controller: the whole-body QP balance controller alone."""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.config import BalanceConfig
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.controllers.protocol import OutputKind


def balance_info(balance: BalanceController) -> dict:
    """The QP's episode labels: strongest strategy used, steps, whether it went down and
    how often its QP fell back."""
    return {"strategy": balance.max_strategy.name.lower(),
            "steps": sum(s.touchdown is not None for s in balance.steps),
            "qp_went_down": balance.went_down,
            "qp_fallbacks": sum(e.kind == "fallback" for e in balance.events)}


class QpController:
    """:class:`BalanceController` (ankle, hip and stepping strategies) as a controller.

    Contract: torque output τ (27,) [N·m] at the QP's 2 ms on the torque model
    (:func:`hybrid_recovery.control.torque_model.load_torque_model`).

    Args:
        config: Controller settings; defaults when None.
    """

    name = "qp"
    physics_dt = CONTROL_DT
    output: OutputKind = "torque"
    joint_target: np.ndarray | None = None

    def __init__(self, config: BalanceConfig | None = None) -> None:
        self.controller = BalanceController(config)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.controller.reset(model, data)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        return self.controller(model, data)

    def info(self) -> dict:
        return balance_info(self.controller)
