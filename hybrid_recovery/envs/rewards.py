"""Reward terms of the paper (§III-E): R = R_I + R_II + R_III, each a pure batched function.

Every term returns shape (N,). The terms are written against the array API standard
(``array_api_compat``): the same code computes them on numpy arrays (the CPU path) and on
torch tensors on any device. :data:`REWARD_TERMS` lists them with their weights;
:func:`compute_rewards` applies ``value × weight × Δt`` in one place and returns the
per-term contributions for logging as ``reward/<name>``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic

from array_api_compat import array_namespace

from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.envs.config import RewardConfig


@dataclass
class RewardState(Generic[Array]):
    """The balance and actuation quantities the terms read; leading dimension N.

    Attributes:
        height: h_c, CoM height above the ground, (N,) [m].
        height_vel: ḣ_c, (N,) [m/s].
        com_distance: d_CoM, signed distance of the CoM projection to C, (N,) [m].
        cp_distance: d_CP, signed distance of ξ to C_feet, (N,) [m].
        net_force: F_net = Δp_l/Δt, (N, 3) [N].
        net_torque: τ_net = ΔL/Δt, (N, 3) [N·m].
        torque: applied joint torques τ, (N, 27) [N·m].
        limit_violation: Σ joint-position excess beyond the soft limits, (N,) [rad].
        speed_violation: Σ_j max(|q̇_j| / ω_max,j − 1, 0), joint speed beyond the velocity
            limits as a share of them, (N,) [-].
        action: a_t, (N, 27).
        last_action: a_{t−1}, (N, 27).
        gravity_b: torso projected gravity, (N, 3).
        support_contacts: number of hand and elbow contacts bearing load, (N,).
        foot_force: normal contact force on each foot (left, right), (N, 2) [N].
        foot_up: z component of each foot's sole normal, u_z ∈ [−1, 1], (N, 2).
        weight: m g of each env's robot, (N,) [N].
        terminated: early termination (not timeout), (N,) bool.
    """

    height: Array
    height_vel: Array
    com_distance: Array
    cp_distance: Array
    net_force: Array
    net_torque: Array
    torque: Array
    limit_violation: Array
    speed_violation: Array
    action: Array
    last_action: Array
    gravity_b: Array
    support_contacts: Array
    foot_force: Array
    foot_up: Array
    weight: Array
    terminated: Array


# ---------------------------------------------------------------- Group I: vertical recovery
def height_gaussian(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_height = exp(−(h_c − h*)² / σ_h²) ∈ (0, 1]."""
    xp = array_namespace(s.height)
    return xp.exp(-xp.square(s.height - h_star) / c.sigma_height**2)


def rise_velocity(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_rise = α_r max(ḣ_c, 0) 1[h_c < h* − δ_h]: off inside the dead band."""
    xp = array_namespace(s.height)
    rising = xp.maximum(s.height_vel, 0.0)
    return c.alpha_rise * rising * (s.height < h_star - c.height_band)


def fall_velocity_sq(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_fall = −α_f max(−ḣ_c, 0)², off inside the dead band |h_c − h*| < δ_h."""
    xp = array_namespace(s.height)
    outside = xp.abs(s.height - h_star) >= c.height_band
    return -c.alpha_fall * xp.square(xp.maximum(-s.height_vel, 0.0)) * outside


def stability_band(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_stab = α_s 1[|h_c − h*| < δ_h] − α_v |ḣ_c|, acting only inside the band."""
    xp = array_namespace(s.height)
    inside = xp.abs(s.height - h_star) < c.height_band
    return (c.alpha_stab - c.alpha_stab_vel * xp.abs(s.height_vel)) * inside


# ---------------------------------------------------------------- Group II: balance
def com_support_exp(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_CoM = exp(−d_CoM² / σ_c²); 1 anywhere inside C (d ≤ 0)."""
    xp = array_namespace(s.height)
    d = xp.maximum(s.com_distance, 0.0)
    return xp.exp(-xp.square(d) / c.sigma_com**2)


def capture_point_exp(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_CP = exp(−d_CP² / σ_ξ²); 1 anywhere inside C_feet (d ≤ 0)."""
    xp = array_namespace(s.height)
    d = xp.maximum(s.cp_distance, 0.0)
    return xp.exp(-xp.square(d) / c.sigma_cp**2)


def momentum_rate_sq(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_mom = −α_ℓ ‖F_net‖² − α_L ‖τ_net‖²."""
    xp = array_namespace(s.height)
    return -(c.alpha_lin * xp.sum(xp.square(s.net_force), axis=-1)
             + c.alpha_ang * xp.sum(xp.square(s.net_torque), axis=-1))


# ---------------------------------------------------------------- Group III: regularisation
def torque_sq(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """−Σ τ² [(N·m)²]."""
    xp = array_namespace(s.height)
    return -xp.sum(xp.square(s.torque), axis=-1)


def joint_limit(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """−Σ excess of q beyond the soft position limits [rad]."""
    return -s.limit_violation


def joint_speed(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """−Σ_j max(|q̇_j| / ω_max,j − 1, 0): joint speed beyond the velocity limits [-]."""
    return -s.speed_violation


def action_rate_sq(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """−‖a_t − a_{t−1}‖²."""
    xp = array_namespace(s.height)
    return -xp.sum(xp.square(s.action - s.last_action), axis=-1)


def orientation_sq(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """−‖g_b,xy‖²: torso misalignment with gravity (0 upright, −1 lying)."""
    xp = array_namespace(s.height)
    return -xp.sum(xp.square(s.gravity_b[:, :2]), axis=-1)


def support_contact(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """Hand and elbow support (count, capped at 2), paid only while h_c < the gate height."""
    xp = array_namespace(s.height)
    return xp.minimum(s.support_contacts, 2.0) * (s.height < c.contact_gate_height)


def feet_load(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """r_feet = min(1, Σ_f F_f clip((u_z,f − u_min) / (1 − u_min), 0, 1) / (m g)) ∈ [0, 1]:
    the share of the weight on flat feet."""
    xp = array_namespace(s.height)
    flat = xp.clip((s.foot_up - c.feet_flat) / (1.0 - c.feet_flat), 0.0, 1.0)
    return xp.minimum(xp.sum(s.foot_force * flat, axis=-1) / s.weight, 1.0)


def alive(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """1 per step survived."""
    xp = array_namespace(s.height)
    return xp.ones_like(s.height)


def termination(s: RewardState[Array], c: RewardConfig, h_star: float) -> Array:
    """1 on an early termination (timeouts excluded), times the negative weight."""
    xp = array_namespace(s.height)
    return xp.astype(s.terminated, s.height.dtype)


Term = Callable[[RewardState[Any], RewardConfig, float], Any]

REWARD_TERMS: tuple[tuple[str, str, Term], ...] = (
    # name, weight field of RewardConfig, function
    ("height", "w_height", height_gaussian),
    ("rise", "w_rise", rise_velocity),
    ("fall", "w_fall", fall_velocity_sq),
    ("stab", "w_stab", stability_band),
    ("com", "w_com", com_support_exp),
    ("cp", "w_cp", capture_point_exp),
    ("mom", "w_mom", momentum_rate_sq),
    ("torque", "w_torque", torque_sq),
    ("joint_limit", "w_joint_limit", joint_limit),
    ("joint_speed", "w_joint_speed", joint_speed),
    ("action_rate", "w_action_rate", action_rate_sq),
    ("orient", "w_orient", orientation_sq),
    ("contact", "w_contact", support_contact),
    ("feet", "w_feet", feet_load),
    ("alive", "w_alive", alive),
    ("termination", "w_termination", termination),
)
"""The reward table: Group I (height … stab), II (com, cp, mom), III (the rest)."""

CAPTURE_POINT_TERMS = ("com", "cp")
"""Terms removed by the capture-point ablation (``RewardConfig.use_capture_point``)."""


def compute_rewards(
    s: RewardState[Array], c: RewardConfig, h_star: float, dt: float
) -> tuple[Array, dict[str, Array]]:
    """R = Σ_term value × weight × Δt.

    Returns:
        (total (N,), per-term contributions {name: (N,)}).
    """
    total = array_namespace(s.height).zeros_like(s.height)
    parts: dict[str, Array] = {}
    for name, weight_field, fn in REWARD_TERMS:
        weight = getattr(c, weight_field)
        if weight == 0.0 or (not c.use_capture_point and name in CAPTURE_POINT_TERMS):
            continue
        value = fn(s, c, h_star) * (weight * dt)
        parts[name] = value
        total += value
    return total, parts
