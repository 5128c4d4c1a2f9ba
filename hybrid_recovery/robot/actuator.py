"""The motors' torque–speed curve: the DC-motor model of the available joint torque.

``ideal``: every joint gives ±τ_lim at any speed. ``dc``: the torque a joint can give
falls linearly with its speed in the driving direction and vanishes at ω_max,

    τ ∈ [max(−τ_lim, τ_sat (−1 − ω/ω_max)), min(τ_lim, τ_sat (1 − ω/ω_max))],

with ω_max the manufacturer's velocity limits (``constants.VELOCITY_LIMITS``) and τ_sat =
:data:`SATURATION_RATIO` · τ_lim. Braking (τ against ω) keeps its full τ_lim.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from hybrid_recovery.robot import constants

Actuator = Literal["ideal", "dc"]
"""The motor models: ``ideal`` (±τ_lim at any speed) or ``dc`` (the torque–speed curve)."""
ACTUATORS: tuple[str, ...] = ("ideal", "dc")

SATURATION_RATIO = 1.0
"""τ_sat / τ_lim of the DC model. Unitree publishes only an effort and a velocity limit per
joint (the URDF), no stall torque or no-load speed; at 1 the curve uses no other number:
τ_lim at rest, falling to 0 at ω_max (the URDF limit read as the no-load speed). Isaac
Lab's DC-motor configurations of Unitree's legged robots make the same choice
(``saturation_effort = effort_limit``). It is the most conservative of the usual values
(ANYmal's is 1.5: full torque up to ω_max / 3)."""


def check_actuator(name: str) -> None:
    """Refuses an unknown motor model.

    Raises:
        ValueError: ``unknown actuator 'x': choose one of ['ideal', 'dc']``.
    """
    if name not in ACTUATORS:
        raise ValueError(f"unknown actuator '{name}': choose one of {list(ACTUATORS)}")


def dc_torque_limits(velocity: np.ndarray, effort: np.ndarray,
                     velocity_limit: np.ndarray = constants.VELOCITY_LIMITS,
                     saturation_ratio: float = SATURATION_RATIO,
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The DC model's available torque interval [τ_low, τ_high] at joint speeds ω.

    τ_high = min(τ_lim, τ_sat (1 − ω/ω_max)), τ_low = max(−τ_lim, τ_sat (−1 − ω/ω_max)),
    τ_sat = ``saturation_ratio`` · τ_lim; each bound then clipped so that 0 stays inside
    (a driver can always command no current; beyond 2 ω_max the formula's interval would
    otherwise be empty).

    Args:
        velocity: joint speeds ω, shape (..., 27) [rad/s].
        effort: effort limits τ_lim, broadcastable to ``velocity`` [N·m] (> 0).
        velocity_limit: ω_max, broadcastable [rad/s] (> 0).
        saturation_ratio: τ_sat / τ_lim.

    Returns:
        (τ_low, τ_high), each of ``velocity``'s shape [N·m], τ_low ≤ 0 ≤ τ_high.
    """
    ratio = velocity / velocity_limit
    saturation = saturation_ratio * effort
    high = np.clip(saturation * (1.0 - ratio), 0.0, effort)
    low = np.clip(saturation * (-1.0 - ratio), -effort, 0.0)
    return low, high


def torque_limits(actuator: str, velocity: np.ndarray, effort: np.ndarray,
                  saturation_ratio: float = SATURATION_RATIO,
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The available torque interval of motor model ``actuator`` (``ideal``: ±τ_lim).

    Args:
        actuator: ``ideal`` or ``dc``.
        velocity: joint speeds ω, shape (..., 27) [rad/s].
        effort: τ_lim, broadcastable to ``velocity`` [N·m].
        saturation_ratio: τ_sat / τ_lim of the DC model.

    Returns:
        (τ_low, τ_high), each of ``velocity``'s shape [N·m].
    """
    if actuator == "dc":
        return dc_torque_limits(velocity, effort, saturation_ratio=saturation_ratio)
    high = np.broadcast_to(effort, np.shape(velocity)).astype(float)
    return -high, high
