"""The ``zero`` controller: PD targets at the default pose."""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.controllers.protocol import OutputKind
from hybrid_recovery.robot import constants


class ZeroController:
    """Zero actions: q_ref = q* (the default pose, the policy's action origin) every step.

    Contract: position output at 5 ms; the state is not read.
    """

    name = "zero"
    physics_dt = 0.005
    output: OutputKind = "position"
    joint_target: np.ndarray | None = None

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        del model, data

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        return constants.DEFAULT_JOINT_POS

    def info(self) -> dict:
        return {}
