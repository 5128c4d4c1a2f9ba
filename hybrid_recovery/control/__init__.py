"""Model-based control: the whole-body QP balance controller and the hybrid supervisor.

Controllers share one interface on a torque-controlled H1-2 (:func:`load_torque_model`,
``ctrl = τ``, dt = 2 ms): ``reset(model, data)`` then ``τ = controller(model, data)``,
shape (27,) [N·m] in motor order, every physics step.
"""

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.config import (
    BalanceConfig,
    DcmConfig,
    QpConfig,
    SteppingConfig,
    SupervisorConfig,
    default_config,
)
from hybrid_recovery.control.diagnostics import Capturability, Event, Strategy, TickDiagnostics
from hybrid_recovery.control.policy_controller import PolicyController
from hybrid_recovery.control.rollout import Push, SensorNoise, run_episode, standing_data
from hybrid_recovery.control.supervisor import HybridSupervisor
from hybrid_recovery.control.torque_model import CONTROL_DT, load_torque_model, torque_spec
from hybrid_recovery.policy import OnnxPolicy

__all__ = [
    "CONTROL_DT",
    "BalanceConfig",
    "BalanceController",
    "Capturability",
    "DcmConfig",
    "Event",
    "HybridSupervisor",
    "OnnxPolicy",
    "PolicyController",
    "Push",
    "QpConfig",
    "SensorNoise",
    "SteppingConfig",
    "Strategy",
    "SupervisorConfig",
    "TickDiagnostics",
    "default_config",
    "load_torque_model",
    "run_episode",
    "standing_data",
    "torque_spec",
]
