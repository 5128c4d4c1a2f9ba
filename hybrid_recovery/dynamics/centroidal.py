"""Net centroidal wrench from consecutive momenta (paper §III-E2, reward r_mom)."""

from __future__ import annotations

import numpy as np


def net_centroidal_wrench(
    linear_momentum: np.ndarray,
    angular_momentum: np.ndarray,
    prev_linear_momentum: np.ndarray,
    prev_angular_momentum: np.ndarray,
    dt: float,
) -> tuple[np.ndarray, np.ndarray]:
    """F_net = Δp_l / Δt and τ_net = ΔL / Δt from two consecutive states.

    Args:
        linear_momentum: p_l(t), shape (..., 3) [kg·m/s].
        angular_momentum: L(t) about the CoM, shape (..., 3) [kg·m²/s].
        prev_linear_momentum: p_l(t − Δt), shape (..., 3).
        prev_angular_momentum: L(t − Δt), shape (..., 3).
        dt: Δt > 0 [s].

    Returns:
        (F_net [N], τ_net [N·m]), each shape (..., 3).
    """
    if not dt > 0.0:
        raise ValueError(f"dt must be > 0, got {dt}")
    force = (np.asarray(linear_momentum) - prev_linear_momentum) / dt
    torque = (np.asarray(angular_momentum) - prev_angular_momentum) / dt
    return force, torque
