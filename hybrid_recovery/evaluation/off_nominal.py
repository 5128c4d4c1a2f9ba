"""An off-nominal robot in an evaluation trial: weak motors, a torso payload, an actuation
delay (:class:`~hybrid_recovery.evaluation.scenario.Scenario`'s ``motor_strength``,
``payload``, ``delay``).

The simulated model (the plant) changes; every controller keeps computing on the nominal
model, as a controller on the robot would: it does not know the payload or the weaker
motors, and its output reaches the motors late.
"""

from __future__ import annotations

from collections import deque

import mujoco
import numpy as np

from hybrid_recovery.robot import constants


def apply_off_nominal(model: mujoco.MjModel, motor_strength: float, payload: float) -> None:
    """Makes ``model`` (one actuator per joint, motor order) the off-nominal plant in place:
    the torso's mass m_torso + ``payload`` [kg] (a point mass at its centre of mass, so
    its inertia about that point is unchanged) and every actuator's force clamped to
    ±``motor_strength`` · τ_lim (nothing where both are nominal)."""
    if payload != 0.0:
        torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, constants.TORSO_BODY)
        model.body_mass[torso] += payload
    if motor_strength != 1.0:
        limit = motor_strength * constants.EFFORT_LIMITS
        model.actuator_forcelimited[:] = 1
        model.actuator_forcerange[:] = np.stack([-limit, limit], 1)


def delay_steps(delay: float, timestep: float) -> int:
    """The delay [s] in whole physics steps of ``timestep`` [s] (rounded)."""
    return int(round(delay / timestep))


class ActuationDelay:
    """A FIFO of controller outputs: what goes in at step k comes out at step k + n.

    Args:
        steps: n ≥ 0 physics steps.
        first: the output applied before the controller's first n outputs arrive, e.g.
            the trial's initial ``ctrl`` (nu,).
    """

    def __init__(self, steps: int, first: np.ndarray) -> None:
        self.steps = steps
        self._queue: deque[np.ndarray] = deque([first.copy()] * steps)

    def __call__(self, command: np.ndarray) -> np.ndarray:
        """The output to apply now (nu,), given this step's ``command`` (nu,)."""
        if self.steps == 0:
            return command
        self._queue.append(np.array(command, copy=True))
        return self._queue.popleft()
