"""Capture steps: when ankle + hip no longer suffice, and where to put the swing foot.

A step is planned from the 1-step capture region of the LIP (Koolen et al. 2012;
:func:`hybrid_recovery.dynamics.capturability.one_step_capture_region`): with the CoP in
the stance sole S until touchdown after the remaining swing time t_s, the new sole
centre must lie within r_max of the capture point at touchdown and within l_max of the
stance sole. The target is the point of that region, cut by a no-crossing half-plane,
(shrunk by a margin against tracking errors) closest to ξ_td + (lateral offset away from
the stance), where
ξ_td = r + (ξ₀ − r) e^{ω t_s} with r the point of S nearest to ξ₀. The swing foot is the
one whose step is shortest among those that capture.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hybrid_recovery.control.config import SteppingConfig
from hybrid_recovery.control.diagnostics import Capturability
from hybrid_recovery.control.polygon import (
    clip_halfplane,
    closest_point,
    convex_hull,
    shrink,
    signed_distance_scalar,
)
from hybrid_recovery.dynamics.capturability import n_step_capture_margin, one_step_capture_region

LEFT, RIGHT = 0, 1


@dataclass
class StepPlan:
    """A planned capture step (world frame, ground plane).

    Attributes:
        swing: Swing foot, 0 left / 1 right.
        target: Touchdown sole centre, shape (2,) [m].
        region: 1-step capture region ∩ no-crossing half-plane, shape (P, 2) [m]; may
            be empty (0, 2) when no single step captures.
        capturable: ``target`` lies in a non-empty capture region.
        stance_cop: r, the CoP assumed in the stance sole, shape (2,) [m].
        capture_at_touchdown: ξ_td, shape (2,) [m].
    """

    swing: int
    target: np.ndarray
    region: np.ndarray
    capturable: bool
    stance_cop: np.ndarray
    capture_at_touchdown: np.ndarray


@dataclass
class StepRecord:
    """A step as it happened, for logs and tests.

    Attributes:
        start_time: Lift-off time [s].
        swing: 0 left / 1 right.
        first_plan: The plan at lift-off.
        last_plan: The last re-plan (its target is where the swing aimed).
        touchdown_time: [s], None while swinging.
        touchdown: Sole centre at touchdown, shape (2,) [m], None while swinging.
    """

    start_time: float
    swing: int
    first_plan: StepPlan
    last_plan: StepPlan
    touchdown_time: float | None = None
    touchdown: np.ndarray | None = None


def _lateral_axis(stance_rotation: np.ndarray) -> np.ndarray:
    """Unit left axis ŷ of the stance sole projected on the ground, shape (2,)."""
    axis = stance_rotation[:2, 1]
    return axis / max(np.linalg.norm(axis), 1e-9)


def plan_for_swing(
    swing: int,
    capture_point: np.ndarray,
    omega: float,
    feet_xy: np.ndarray,
    stance_corners: np.ndarray,
    stance_rotation: np.ndarray,
    time_to_touchdown: float,
    cfg: SteppingConfig,
    cop_margin: float,
) -> StepPlan:
    """The step of one given swing foot.

    Args:
        swing: 0 left / 1 right.
        capture_point: ξ₀, shape (2,) [m].
        omega: ω [1/s].
        feet_xy: Sole centres (left, right), shape (2, 2) [m].
        stance_corners: Stance sole corners, shape (4, 2) or (4, 3) [m].
        stance_rotation: Stance sole orientation, shape (3, 3).
        time_to_touchdown: t_s > 0 [s].
        cfg: Stepping settings.
        cop_margin: CoP margin inside the stance sole [m].

    Returns:
        The :class:`StepPlan`.
    """
    stance = 1 - swing
    sole = convex_hull(np.asarray(stance_corners)[:, :2])
    xi = np.asarray(capture_point, dtype=float)
    t_s = max(time_to_touchdown, 1e-3)
    cop = closest_point(xi, shrink(sole, cop_margin))
    xi_td = cop + (xi - cop) * np.exp(omega * t_s)
    lateral = _lateral_axis(stance_rotation)
    side = 1.0 if swing == LEFT else -1.0  # the swing sole stays on its own side
    normal = -side * lateral
    offset = -side * lateral @ feet_xy[stance] - cfg.min_width
    region = one_step_capture_region(
        xi, sole, omega=omega, step_length=cfg.step_length, foot_size=cfg.foot_size,
        min_step_time=t_s, foot_center=feet_xy[stance], num_vertices=cfg.region_vertices,
    )
    if len(region) >= 3:
        region = clip_halfplane(region, normal, offset)
    nominal = xi_td + side * cfg.lateral_offset * lateral
    if len(region) >= 3:
        target = closest_point(nominal, shrink(region, cfg.target_margin))
        return StepPlan(swing, target, region, True, cop, xi_td)
    angle = 2.0 * np.pi * np.arange(32) / 32
    reach = feet_xy[stance] + cfg.step_length * np.stack([np.cos(angle), np.sin(angle)], 1)
    reach = clip_halfplane(reach, normal, offset)
    target = closest_point(nominal, reach) if len(reach) else feet_xy[swing].copy()
    return StepPlan(swing, target, np.zeros((0, 2)), False, cop, xi_td)


def plan_step(
    capture_point: np.ndarray,
    omega: float,
    feet_xy: np.ndarray,
    feet_corners: np.ndarray,
    feet_rotation: np.ndarray,
    cfg: SteppingConfig,
    cop_margin: float,
) -> StepPlan:
    """The better capture step over both swing feet (shortest capturing step wins).

    Args:
        capture_point: ξ₀, shape (2,) [m].
        omega: ω [1/s].
        feet_xy: Sole centres (left, right), shape (2, 2) [m].
        feet_corners: Sole corners, shape (2, 4, 2|3) [m].
        feet_rotation: Sole orientations, shape (2, 3, 3).
        cfg: Stepping settings (the full swing time ``cfg.swing_time`` is used).
        cop_margin: CoP margin inside the stance sole [m].

    Returns:
        The chosen :class:`StepPlan`.
    """
    plans = [
        plan_for_swing(swing, capture_point, omega, feet_xy, feet_corners[1 - swing],
                       feet_rotation[1 - swing], cfg.swing_time, cfg, cop_margin)
        for swing in (LEFT, RIGHT)
    ]

    def cost(plan: StepPlan) -> float:
        length = float(np.linalg.norm(plan.target - feet_xy[plan.swing]))
        return length if plan.capturable else 1e3 + float(
            np.linalg.norm(plan.target - plan.capture_at_touchdown))

    return min(plans, key=cost)


def touchdown_margin(plan: StepPlan, feet_xy: np.ndarray, stance_corners: np.ndarray) -> float:
    """−d(ξ_td, C_td): how far the predicted ξ at touchdown lies inside the double support.

    C_td is the hull of the stance CoP corners and the same corners moved to the target
    (the sole lands with the stance sole's shape and heading). Positive inside [m].

    Args:
        plan: The step.
        feet_xy: Sole centres (left, right), shape (2, 2) [m].
        stance_corners: Stance CoP corners, shape (4, 2|3) [m].
    """
    stance = np.asarray(stance_corners)[:, :2]
    moved = stance - feet_xy[1 - plan.swing] + plan.target
    hull = convex_hull(np.vstack([stance, moved]))
    return -signed_distance_scalar(plan.capture_at_touchdown, hull)


def step_capturability(plan: StepPlan, feet_xy: np.ndarray, stance_corners: np.ndarray,
                       hip_reach: float, omega: float, steps_after: int, cfg: SteppingConfig
                       ) -> Capturability:
    """ONE_STEP, N_STEP or NONE for a state that ankle and hip alone cannot capture.

    ONE_STEP when the step lands in its 1-step capture region, or when ξ_td ends inside
    the double support of stance and target soles give or take the hip's reach (the LIP
    region with r_max = a sole is conservative: after touchdown the CoP may use both
    soles). N_STEP when ‖ξ_td − target‖ is within d_N of the target for the N =
    ``steps_after`` steps left (r_max widened by the hip reach). NONE otherwise.

    Args:
        plan: The (planned or ongoing) step, with ξ_td.
        feet_xy: Sole centres (left, right), shape (2, 2) [m].
        stance_corners: Stance CoP corners, shape (4, 2|3) [m].
        hip_reach: The hip strategy's reach [m].
        omega: ω [1/s].
        steps_after: Steps still allowed after this one.
        cfg: Stepping settings.
    """
    if plan.capturable or touchdown_margin(plan, feet_xy, stance_corners) >= -hip_reach:
        return Capturability.ONE_STEP
    margin = n_step_capture_margin(
        float(np.linalg.norm(plan.capture_at_touchdown - plan.target)), max(steps_after, 0),
        omega=omega, step_length=cfg.step_length, foot_size=cfg.foot_size + hip_reach,
        min_step_time=cfg.swing_time)
    return Capturability.N_STEP if margin >= 0.0 else Capturability.NONE
