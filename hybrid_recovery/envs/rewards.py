"""Reward terms of the paper (§III-E): R = R_I + R_II + R_III, each a pure batched function.

Every term returns shape (N,). :data:`REWARD_TERMS` lists them with their weights;
:func:`compute_rewards` applies ``value × weight × Δt`` in one place and returns the
per-term contributions for logging as ``reward/<name>``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hybrid_recovery.envs.config import RewardConfig


@dataclass
class RewardState:
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
        action: a_t, (N, 27).
        last_action: a_{t−1}, (N, 27).
        gravity_b: torso projected gravity, (N, 3).
        support_contacts: number of hand and elbow contacts bearing load, (N,).
        foot_force: normal contact force on each foot (left, right), (N, 2) [N].
        foot_up: z component of each foot's sole normal, u_z ∈ [−1, 1], (N, 2).
        weight: m g of each env's robot, (N,) [N].
        terminated: early termination (not timeout), (N,) bool.
    """

    height: np.ndarray
    height_vel: np.ndarray
    com_distance: np.ndarray
    cp_distance: np.ndarray
    net_force: np.ndarray
    net_torque: np.ndarray
    torque: np.ndarray
    limit_violation: np.ndarray
    action: np.ndarray
    last_action: np.ndarray
    gravity_b: np.ndarray
    support_contacts: np.ndarray
    foot_force: np.ndarray
    foot_up: np.ndarray
    weight: np.ndarray
    terminated: np.ndarray


# ---------------------------------------------------------------- Group I: vertical recovery
def height_gaussian(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_height = exp(−(h_c − h*)² / σ_h²) ∈ (0, 1]."""
    return np.exp(-np.square(s.height - h_star) / c.sigma_height**2)


def rise_velocity(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_rise = α_r max(ḣ_c, 0) 1[h_c < h* − δ_h]: off inside the dead band."""
    rising = np.maximum(s.height_vel, 0.0)
    return c.alpha_rise * rising * (s.height < h_star - c.height_band)


def fall_velocity_sq(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_fall = −α_f max(−ḣ_c, 0)², off inside the dead band |h_c − h*| < δ_h."""
    outside = np.abs(s.height - h_star) >= c.height_band
    return -c.alpha_fall * np.square(np.maximum(-s.height_vel, 0.0)) * outside


def stability_band(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_stab = α_s 1[|h_c − h*| < δ_h] − α_v |ḣ_c|, acting only inside the band."""
    inside = np.abs(s.height - h_star) < c.height_band
    return (c.alpha_stab - c.alpha_stab_vel * np.abs(s.height_vel)) * inside


# ---------------------------------------------------------------- Group II: balance
def com_support_exp(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_CoM = exp(−d_CoM² / σ_c²); 1 anywhere inside C (d ≤ 0)."""
    d = np.maximum(s.com_distance, 0.0)
    return np.exp(-np.square(d) / c.sigma_com**2)


def capture_point_exp(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_CP = exp(−d_CP² / σ_ξ²); 1 anywhere inside C_feet (d ≤ 0)."""
    d = np.maximum(s.cp_distance, 0.0)
    return np.exp(-np.square(d) / c.sigma_cp**2)


def momentum_rate_sq(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_mom = −α_ℓ ‖F_net‖² − α_L ‖τ_net‖²."""
    return -(c.alpha_lin * np.sum(np.square(s.net_force), -1)
             + c.alpha_ang * np.sum(np.square(s.net_torque), -1))


# ---------------------------------------------------------------- Group III: regularisation
def torque_sq(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """−Σ τ² [(N·m)²]."""
    return -np.sum(np.square(s.torque), -1)


def joint_limit(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """−Σ excess of q beyond the soft position limits [rad]."""
    return -s.limit_violation


def action_rate_sq(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """−‖a_t − a_{t−1}‖²."""
    return -np.sum(np.square(s.action - s.last_action), -1)


def orientation_sq(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """−‖g_b,xy‖²: torso misalignment with gravity (0 upright, −1 lying)."""
    return -np.sum(np.square(s.gravity_b[:, :2]), -1)


def support_contact(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """Hand and elbow support (count, capped at 2), paid only while h_c < the gate height."""
    return np.minimum(s.support_contacts, 2.0) * (s.height < c.contact_gate_height)


def feet_load(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """r_feet = min(1, Σ_f F_f clip((u_z,f − u_min) / (1 − u_min), 0, 1) / (m g)) ∈ [0, 1]:
    the share of the weight on flat feet."""
    flat = np.clip((s.foot_up - c.feet_flat) / (1.0 - c.feet_flat), 0.0, 1.0)
    return np.minimum(np.sum(s.foot_force * flat, -1) / s.weight, 1.0)


def alive(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """1 per step survived."""
    return np.ones_like(s.height)


def termination(s: RewardState, c: RewardConfig, h_star: float) -> np.ndarray:
    """1 on an early termination (timeouts excluded), times the negative weight."""
    return s.terminated.astype(float)


Term = Callable[[RewardState, RewardConfig, float], np.ndarray]

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
    s: RewardState, c: RewardConfig, h_star: float, dt: float
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """R = Σ_term value × weight × Δt.

    Returns:
        (total (N,), per-term contributions {name: (N,)}).
    """
    total = np.zeros_like(s.height)
    parts: dict[str, np.ndarray] = {}
    for name, weight_field, fn in REWARD_TERMS:
        weight = getattr(c, weight_field)
        if weight == 0.0 or (not c.use_capture_point and name in CAPTURE_POINT_TERMS):
            continue
        value = fn(s, c, h_star) * (weight * dt)
        parts[name] = value
        total += value
    return total, parts
