"""Capture-point (DCM) control and its split into the ankle and hip strategies.

Englsberger et al. 2015 / Koolen et al. 2016. With ω = √(g/h) and the capture point
ξ = c + ċ/ω, the LIP obeys ξ̇ = ω (ξ − r_cmp). Tracking a reference ξ_ref(t) whose own
CMP is r_ref (ξ̇_ref = ω (ξ_ref − r_ref)) with

    r_cmp,des = r_ref + (1 + k) (ξ − ξ_ref)

gives ξ̇ − ξ̇_ref = −k ω (ξ − ξ_ref). Standing still (ξ_ref = r_ref) it is the familiar
r_cmp,des = ξ + k (ξ − ξ_ref).

* **Ankle strategy**: the CoP r_cop is r_cmp,des clipped into the support polygon C
  shrunk by a margin.
* **Hip strategy**: the rest δ = r_cmp,des − r_cop becomes a centroidal angular momentum
  rate, since r_cmp = r_cop + (L̇_y, −L̇_x) / F_z: L̇_xy = F_z (−δ_y, δ_x), bounded by
  ‖L̇_xy‖ ≤ L̇_max and ‖L_xy‖ ≤ L_max. Without an offset, L̇ = −k_L L damps L back to 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hybrid_recovery.control.config import DcmConfig
from hybrid_recovery.control.polygon import closest_point, shrink
from hybrid_recovery.dynamics import GRAVITY


@dataclass
class DcmCommand:
    """Centroidal targets of one tick (world frame).

    Attributes:
        capture_point: ξ, shape (2,) [m].
        omega: ω [1/s].
        cmp_desired: r_cmp,des, shape (2,) [m].
        cop: r_cop inside the shrunk support polygon, shape (2,) [m].
        cmp: Achieved r_cmp = r_cop + (L̇_y, −L̇_x)/F_z, shape (2,) [m].
        com_acc: c̈_des, shape (3,) [m/s²].
        angular_momentum_rate: L̇_des about the CoM, shape (3,) [N·m].
        hip_offset: ‖δ‖, CMP offset beyond the CoP region [m].
    """

    capture_point: np.ndarray
    omega: float
    cmp_desired: np.ndarray
    cop: np.ndarray
    cmp: np.ndarray
    com_acc: np.ndarray
    angular_momentum_rate: np.ndarray
    hip_offset: float


def _cmp_shift(ldot: np.ndarray, fz: float) -> np.ndarray:
    """r_cmp − r_cop = (L̇_y, −L̇_x) / F_z [m]."""
    return np.array([ldot[1], -ldot[0]]) / fz


def hip_reach(omega: float, fz: float, cfg: DcmConfig) -> float:
    """Largest distance of ξ outside C that the hip strategy can bring back [m].

    The CMP can sit δ = L̇_max/F_z beyond C for T = L_max/L̇_max before L saturates; ξ
    starting e₀ outside returns if e₀ ≤ δ (1 − e^{−ωT}).

    Args:
        omega: ω [1/s].
        fz: Vertical contact force F_z [N].
        cfg: The DCM settings (L̇_max, L_max).
    """
    delta = cfg.max_angular_momentum_rate / fz
    duration = cfg.max_angular_momentum / cfg.max_angular_momentum_rate
    return float(delta * -np.expm1(-omega * duration))


def dcm_command(
    com: np.ndarray,
    com_vel: np.ndarray,
    angular_momentum: np.ndarray,
    xi_ref: np.ndarray,
    cmp_ref: np.ndarray,
    support: np.ndarray,
    height_ref: float,
    mass: float,
    cfg: DcmConfig,
) -> DcmCommand:
    """Desired CoM acceleration and angular momentum rate from the capture-point law.

    Args:
        com: c, shape (3,) [m], ground at z = 0.
        com_vel: ċ, shape (3,) [m/s].
        angular_momentum: L about the CoM, shape (3,) [kg·m²/s].
        xi_ref: ξ_ref, shape (2,) [m].
        cmp_ref: r_ref, the CMP that keeps ξ on ξ_ref, shape (2,) [m].
        support: Support polygon C (counter-clockwise), shape (K, 2) [m].
        height_ref: CoM height target h_ref [m].
        mass: m [kg].
        cfg: Gains and bounds.

    Returns:
        The tick's :class:`DcmCommand`.
    """
    height = max(float(com[2]), 0.1)
    omega = float(np.sqrt(GRAVITY / height))
    xi = com[:2] + com_vel[:2] / omega
    r_des = np.asarray(cmp_ref) + (1.0 + cfg.k_xi) * (xi - np.asarray(xi_ref))
    acc_z = cfg.height_kp * (height_ref - com[2]) - cfg.height_kd * com_vel[2]
    fz = mass * max(GRAVITY + acc_z, 0.2 * GRAVITY)
    region = shrink(support, cfg.cop_margin)
    cop = closest_point(r_des, region)
    delta = r_des - cop
    hip_offset = float(np.linalg.norm(delta))
    l_xy = np.asarray(angular_momentum[:2], dtype=float)
    if hip_offset > cfg.hip_threshold:
        ldot = fz * np.array([-delta[1], delta[0]])
        ldot = _bounded(ldot, cfg.max_angular_momentum_rate)
        l_norm = np.linalg.norm(l_xy)
        if l_norm >= cfg.max_angular_momentum and ldot @ l_xy > 0.0:
            unit = l_xy / l_norm
            ldot = ldot - (ldot @ unit) * unit
    else:
        ldot = _bounded(-cfg.angular_momentum_damping * l_xy, cfg.max_angular_momentum_rate)
        cop = closest_point(r_des - _cmp_shift(ldot, fz), region)
    cmp = cop + _cmp_shift(ldot, fz)
    com_acc = np.array([*(omega**2 * (com[:2] - cmp)), acc_z])
    ldot3 = np.array([ldot[0], ldot[1], -cfg.angular_momentum_damping * angular_momentum[2]])
    return DcmCommand(capture_point=xi, omega=omega, cmp_desired=r_des, cop=cop, cmp=cmp,
                      com_acc=com_acc, angular_momentum_rate=ldot3, hip_offset=hip_offset)


def _bounded(vec: np.ndarray, bound: float) -> np.ndarray:
    """vec scaled down to ‖vec‖ ≤ bound."""
    norm = np.linalg.norm(vec)
    return vec if norm <= bound else vec * (bound / norm)
