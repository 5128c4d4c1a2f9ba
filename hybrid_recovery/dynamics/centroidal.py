"""Net centroidal wrench from consecutive momenta (paper §III-E2, reward r_mom)."""

from __future__ import annotations

from hybrid_recovery.dynamics.arrays import Array, as_arrays


def net_centroidal_wrench(
    linear_momentum: Array,
    angular_momentum: Array,
    prev_linear_momentum: Array,
    prev_angular_momentum: Array,
    dt: float,
) -> tuple[Array, Array]:
    """F_net = Δp_l / Δt and τ_net = ΔL / Δt from two consecutive states (numpy arrays or
    torch tensors).

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
    linear_momentum, angular_momentum, prev_linear_momentum, prev_angular_momentum = as_arrays(
        linear_momentum, angular_momentum, prev_linear_momentum, prev_angular_momentum)
    force = (linear_momentum - prev_linear_momentum) / dt
    torque = (angular_momentum - prev_angular_momentum) / dt
    return force, torque
