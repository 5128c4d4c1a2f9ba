"""What every controller provides: the :class:`Controller` protocol and its output kinds."""

from __future__ import annotations

from typing import Literal, Protocol, runtime_checkable

import mujoco
import numpy as np

OutputKind = Literal["torque", "position"]
"""What a controller's step returns: ``"torque"``, joint torques τ (27,) [N·m] for a
torque-controlled model (``ctrl = τ``; on the robot: feed-forward torque with kp = 0);
``"position"``, joint targets q_ref (27,) [rad] for PD servos (the robot's drivers)."""

OUTPUT_KINDS: tuple[OutputKind, ...] = ("torque", "position")


@runtime_checkable
class Controller(Protocol):
    """A controller of the H1-2, called once per physics step.

    Attributes:
        name: Its registry name (``hybrid_recovery.controllers.CONTROLLERS``), with the
            policy it runs where it runs one (``onnx:PATH``).
        physics_dt: The physics step it is designed for [s]: the period of its calls.
        output: What :meth:`__call__` returns (:data:`OutputKind`).
        joint_target: For a torque output that is, this step, the PD law
            τ = K_P (q_ref − q) − K_D q̇ on joint targets (``constants.KP``/``KD``): those
            targets q_ref (27,) [rad], which the robot's drivers can track themselves;
            None otherwise (and always for a position output).
    """

    name: str
    physics_dt: float
    output: OutputKind
    joint_target: np.ndarray | None

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Start of an episode from the state in ``data``."""

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """The joint commands (27,) in motor order, of kind :attr:`output`."""

    def info(self) -> dict:
        """What it did in the episode so far (labels for the evaluation's rows)."""
