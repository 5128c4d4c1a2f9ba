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

import math
from dataclasses import dataclass

import numpy as np

from hybrid_recovery.control.config import DcmConfig
from hybrid_recovery.control.polygon import closest_xy, shrink_vertices
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


def _cmp_shift(ldot: tuple[float, float], fz: float) -> tuple[float, float]:
    """r_cmp − r_cop = (L̇_y, −L̇_x) / F_z [m]."""
    return ldot[1] / fz, -ldot[0] / fz


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
    # Two-vectors as float pairs: per tick, NumPy calls on (2,) arrays cost more than the
    # arithmetic (the same IEEE operations, so the same numbers).
    cx, cy, cz = np.asarray(com, float).tolist()
    vx, vy, vz = np.asarray(com_vel, float).tolist()
    lx, ly, lz = np.asarray(angular_momentum, float).tolist()
    ref_x, ref_y = np.asarray(xi_ref, float).tolist()
    rcmp_x, rcmp_y = np.asarray(cmp_ref, float).tolist()
    height = max(cz, 0.1)
    omega = math.sqrt(GRAVITY / height)
    xi = (cx + vx / omega, cy + vy / omega)
    gain = 1.0 + cfg.k_xi
    r_des = (rcmp_x + gain * (xi[0] - ref_x), rcmp_y + gain * (xi[1] - ref_y))
    acc_z = cfg.height_kp * (height_ref - cz) - cfg.height_kd * vz
    fz = mass * max(GRAVITY + acc_z, 0.2 * GRAVITY)
    region = shrink_vertices(np.asarray(support, float).tolist(), cfg.cop_margin)
    cop = closest_xy(r_des[0], r_des[1], region)
    dx, dy = r_des[0] - cop[0], r_des[1] - cop[1]
    hip_offset = math.sqrt(dx * dx + dy * dy)
    if hip_offset > cfg.hip_threshold:
        ldot = _bounded((fz * -dy, fz * dx), cfg.max_angular_momentum_rate)
        l_norm = math.sqrt(lx * lx + ly * ly)
        if l_norm >= cfg.max_angular_momentum and ldot[0] * lx + ldot[1] * ly > 0.0:
            ux, uy = lx / l_norm, ly / l_norm
            along = ldot[0] * ux + ldot[1] * uy
            ldot = (ldot[0] - along * ux, ldot[1] - along * uy)
    else:
        damping = -cfg.angular_momentum_damping
        ldot = _bounded((damping * lx, damping * ly), cfg.max_angular_momentum_rate)
        sx, sy = _cmp_shift(ldot, fz)
        cop = closest_xy(r_des[0] - sx, r_des[1] - sy, region)
    sx, sy = _cmp_shift(ldot, fz)
    cmp = (cop[0] + sx, cop[1] + sy)
    omega2 = omega**2
    com_acc = np.array([omega2 * (cx - cmp[0]), omega2 * (cy - cmp[1]), acc_z])
    ldot3 = np.array([ldot[0], ldot[1], -cfg.angular_momentum_damping * lz])
    return DcmCommand(capture_point=np.array(xi), omega=omega, cmp_desired=np.array(r_des),
                      cop=np.array(cop), cmp=np.array(cmp), com_acc=com_acc,
                      angular_momentum_rate=ldot3, hip_offset=hip_offset)


def _bounded(vec: tuple[float, float], bound: float) -> tuple[float, float]:
    """vec scaled down to ‖vec‖ ≤ bound."""
    norm = math.sqrt(vec[0] * vec[0] + vec[1] * vec[1])
    if norm <= bound:
        return vec
    scale = bound / norm
    return vec[0] * scale, vec[1] * scale
