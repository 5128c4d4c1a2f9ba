"""Pure pieces of the QP controller: polygons, the DCM law, swing trajectories, step plans."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.control.config import DcmConfig, SteppingConfig
from hybrid_recovery.control.dcm import dcm_command, hip_reach
from hybrid_recovery.control.polygon import (
    clip_halfplane,
    closest_point,
    convex_hull,
    shrink,
    signed_distance_scalar,
)
from hybrid_recovery.control.stepping import LEFT, RIGHT, plan_for_swing, plan_step
from hybrid_recovery.control.swing import SwingTrajectory
from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.dynamics import support as reference

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
MASS = 67.0


# --- polygons --------------------------------------------------------------------------


def test_hull_and_signed_distance_match_the_dynamics_layer():
    rng = np.random.default_rng(0)
    for _ in range(50):
        points = rng.normal(size=(int(rng.integers(3, 9)), 2))
        hull = convex_hull(points)
        np.testing.assert_allclose(hull, reference.support_polygon(points))
        for p in rng.normal(size=(5, 2)) * 1.5:
            assert signed_distance_scalar(p, hull) == pytest.approx(
                reference.signed_distance(p, hull), abs=1e-12)


def test_closest_point_is_the_projection():
    np.testing.assert_allclose(closest_point([0.3, 0.4], SQUARE), [0.3, 0.4])
    np.testing.assert_allclose(closest_point([2.0, 0.5], SQUARE), [1.0, 0.5])
    np.testing.assert_allclose(closest_point([-1.0, -2.0], SQUARE), [0.0, 0.0])
    rng = np.random.default_rng(1)
    for p in rng.normal(size=(20, 2)) * 2:
        c = closest_point(p, SQUARE)
        assert np.linalg.norm(p - c) == pytest.approx(max(signed_distance_scalar(p, SQUARE), 0.0))


def _brute_force(point: np.ndarray, polygon: np.ndarray) -> tuple[float, np.ndarray]:
    """Signed distance and closest point from 2000 samples along every edge and the edge
    lines' half-planes, one edge at a time (the straightforward reference)."""
    s = np.linspace(0.0, 1.0, 2001)[:, None]
    edges = [(a, b) for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True)]
    boundary = np.concatenate([a + s * (b - a) for a, b in edges])
    distances = np.linalg.norm(boundary - point, axis=1)
    nearest = boundary[np.argmin(distances)]
    normals = [np.array([b[1] - a[1], a[0] - b[0]]) / np.linalg.norm(b - a) for a, b in edges]
    inside = all(n @ (point - a) <= 0.0 for n, (a, _) in zip(normals, edges, strict=True))
    return (-distances.min() if inside else distances.min()), (point if inside else nearest)


def test_signed_distance_and_closest_point_match_a_brute_force_reference():
    """Random convex polygons (3-8 vertices), points inside, outside, on vertices and edges."""
    rng = np.random.default_rng(2)
    for _ in range(40):
        hull = convex_hull(rng.normal(size=(int(rng.integers(3, 9)), 2)) * 0.2)
        points = [*rng.normal(size=(6, 2)) * 0.3, hull[0], 0.5 * (hull[0] + hull[1])]
        for p in points:
            distance, nearest = _brute_force(p, hull)
            assert signed_distance_scalar(p, hull) == pytest.approx(distance, abs=1e-3 * 0.4)
            np.testing.assert_allclose(closest_point(p, hull), nearest, atol=1e-3 * 0.4)
    assert signed_distance_scalar([3.0, 4.0], np.zeros((1, 2))) == pytest.approx(5.0)
    np.testing.assert_allclose(closest_point([2.0, 1.0], SQUARE[:2]), [1.0, 0.0])


def test_shrink_and_clip():
    np.testing.assert_allclose(shrink(SQUARE, 0.1), [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9],
                                                     [0.1, 0.9]])
    np.testing.assert_allclose(shrink(SQUARE, 0.6), [[0.5, 0.5]])  # collapses to its centre
    half = clip_halfplane(SQUARE, np.array([1.0, 0.0]), 0.25)
    np.testing.assert_allclose(convex_hull(half), [[0, 0], [0.25, 0], [0.25, 1], [0, 1]])
    assert clip_halfplane(SQUARE, np.array([1.0, 0.0]), -1.0).shape == (0, 2)


# --- DCM law ---------------------------------------------------------------------------


def _lip_rollout(xi_ref: np.ndarray, com0: np.ndarray, vel0: np.ndarray, support: np.ndarray,
                 cfg: DcmConfig, seconds: float, dt: float = 1e-3):
    """LIP c̈ = ω² (c − r_cmp) under the DCM law; returns ξ(t) and the commands."""
    com = np.array([*com0, 0.9])
    vel = np.array([*vel0, 0.0])
    xis, cmds = [], []
    for _ in range(round(seconds / dt)):
        cmd = dcm_command(com, vel, np.zeros(3), xi_ref, xi_ref, support, 0.9, MASS, cfg)
        xis.append(cmd.capture_point)
        cmds.append(cmd)
        acc = cmd.com_acc.copy()
        acc[2] = 0.0
        vel = vel + acc * dt
        com = com + vel * dt
    return np.array(xis), cmds


def test_static_robot_needs_nothing():
    cfg = DcmConfig()
    cmd = dcm_command(np.array([0.1, 0.2, 0.9]), np.zeros(3), np.zeros(3), np.array([0.1, 0.2]),
                      np.array([0.1, 0.2]), SQUARE - 0.5 + [0.1, 0.2], 0.9, MASS, cfg)
    np.testing.assert_allclose(cmd.capture_point, [0.1, 0.2])
    np.testing.assert_allclose(cmd.cop, [0.1, 0.2])
    np.testing.assert_allclose(cmd.com_acc, 0.0, atol=1e-12)
    np.testing.assert_allclose(cmd.angular_momentum_rate, 0.0)
    assert cmd.omega == pytest.approx(np.sqrt(GRAVITY / 0.9))


def test_ankle_strategy_converges_at_rate_k_omega():
    """Inside C: ξ − ξ_ref decays as e^{−k ω t} (ξ̇ = −k ω (ξ − ξ_ref))."""
    cfg = DcmConfig()
    support = SQUARE - 0.5
    xis, cmds = _lip_rollout(np.zeros(2), np.zeros(2), np.array([0.1, -0.05]), support, cfg,
                             0.5)
    omega = np.sqrt(GRAVITY / 0.9)
    t = 0.3
    expected = xis[0] * np.exp(-cfg.k_xi * omega * t)
    np.testing.assert_allclose(xis[round(t / 1e-3)], expected, rtol=0.02, atol=1e-4)
    assert all(c.hip_offset == 0.0 for c in cmds)


def test_hip_strategy_offsets_the_cmp_with_bounded_angular_momentum_rate():
    cfg = DcmConfig()
    support = np.array([[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]])
    com = np.array([0.05, 0.0, 0.9])
    vel = np.array([0.6, 0.0, 0.0])  # ξ ≈ 0.23 m, outside C
    cmd = dcm_command(com, vel, np.zeros(3), np.zeros(2), np.zeros(2), support, 0.9, MASS, cfg)
    assert cmd.cop[0] == pytest.approx(0.1 - cfg.cop_margin)
    assert cmd.hip_offset > 0.0
    ldot = cmd.angular_momentum_rate
    assert np.linalg.norm(ldot[:2]) == pytest.approx(cfg.max_angular_momentum_rate)
    assert ldot[1] > 0.0 and abs(ldot[0]) < 1e-9  # forward CMP shift: L̇_y > 0
    fz = MASS * (GRAVITY + cmd.com_acc[2])
    np.testing.assert_allclose(cmd.cmp, cmd.cop + np.array([ldot[1], -ldot[0]]) / fz)
    omega = cmd.omega
    np.testing.assert_allclose(cmd.com_acc[:2], omega**2 * (com[:2] - cmd.cmp))
    # Saturated angular momentum: no further increase along L.
    saturated = dcm_command(com, vel, np.array([0.0, 2 * cfg.max_angular_momentum, 0.0]),
                            np.zeros(2), np.zeros(2), support, 0.9, MASS, cfg)
    assert saturated.angular_momentum_rate[1] == pytest.approx(0.0, abs=1e-9)


def test_hip_reach_formula():
    cfg = DcmConfig()
    fz = MASS * GRAVITY
    delta = cfg.max_angular_momentum_rate / fz
    duration = cfg.max_angular_momentum / cfg.max_angular_momentum_rate
    assert hip_reach(3.0, fz, cfg) == pytest.approx(delta * (1 - np.exp(-3.0 * duration)))


# --- swing trajectory --------------------------------------------------------------------


def test_swing_boundary_conditions_and_derivatives():
    start, target = np.array([0.0, -0.16, 0.0]), np.array([0.3, -0.2, -0.01])
    swing = SwingTrajectory(start, target, t_start=1.0, duration=0.4, height=0.07)
    p0, v0, a0 = swing.sample(1.0)
    p1, v1, a1 = swing.sample(1.4)
    np.testing.assert_allclose(p0, start, atol=1e-12)
    np.testing.assert_allclose(p1, target, atol=1e-12)
    for v in (v0, a0, v1, a1):
        np.testing.assert_allclose(v, 0.0, atol=1e-9)
    assert swing.sample(1.2)[0][2] == pytest.approx(0.07 + (target[2] - start[2]) / 2)
    h = 1e-6
    for t in (1.05, 1.17, 1.33):
        pm, vm, _ = swing.sample(t - h)
        pp, vp, _ = swing.sample(t + h)
        _, v, a = swing.sample(t)
        np.testing.assert_allclose((pp - pm) / (2 * h), v, atol=1e-5)
        np.testing.assert_allclose((vp - vm) / (2 * h), a, atol=1e-3)


def test_swing_retarget_is_continuous():
    swing = SwingTrajectory(np.zeros(3), np.array([0.3, 0.0, 0.0]), 0.0, 0.4, 0.05)
    before = swing.sample(0.15)
    swing.retarget(0.15, np.array([0.4, 0.1, 0.0]))
    after = swing.sample(0.15)
    for x, y in zip(before, after, strict=True):
        np.testing.assert_allclose(x, y, atol=1e-9)
    np.testing.assert_allclose(swing.sample(0.4)[0][:2], [0.4, 0.1], atol=1e-12)
    with pytest.raises(ValueError, match="^swing duration must be > 0$"):
        SwingTrajectory(np.zeros(3), np.zeros(3), 0.0, 0.0, 0.05)


# --- step planning -----------------------------------------------------------------------

FEET = np.array([[0.03, 0.163], [0.03, -0.163]])
ROTATIONS = np.stack([np.eye(3), np.eye(3)])


def _corners(xy: np.ndarray) -> np.ndarray:
    return xy + np.array([[0.06, 0.04], [0.06, -0.04], [-0.12, 0.04], [-0.12, -0.04]])


CORNERS = np.stack([_corners(FEET[0]), _corners(FEET[1])])


def test_forward_step_lands_in_the_capture_region():
    cfg = SteppingConfig()
    plan = plan_step(np.array([0.15, 0.0]), 3.3, FEET, CORNERS, ROTATIONS, cfg, 0.01)
    assert plan.capturable
    assert signed_distance_scalar(plan.target, plan.region) <= 1e-9
    stance = FEET[1 - plan.swing]
    assert np.linalg.norm(plan.target - stance) <= cfg.step_length + 1e-9
    assert plan.target[0] > 0.2  # a forward step


@pytest.mark.parametrize("swing", [LEFT, RIGHT])
@pytest.mark.parametrize("xi_y", [0.26, -0.26])
def test_steps_never_cross_the_stance_foot(swing, xi_y):
    """Lateral pushes: whichever foot swings, it stays min_width on its own side."""
    cfg = SteppingConfig()
    plan = plan_for_swing(swing, np.array([0.03, xi_y]), 3.3, FEET, CORNERS[1 - swing],
                          np.eye(3), 0.35, cfg, 0.01)
    side = 1.0 if swing == LEFT else -1.0
    assert side * (plan.target[1] - FEET[1 - swing, 1]) >= cfg.min_width - 1e-9
    if plan.capturable:
        assert signed_distance_scalar(plan.target, plan.region) <= 1e-9


def test_lateral_capture_needs_more_than_one_step():
    """ξ beyond the outer sole edge: stance on the inner foot makes ξ diverge outward
    (ξ_td ≈ r + (ξ − r) e^{ωT}, far beyond reach), stance on the outer foot needs a
    crossing step: no single step captures, and the plan says so."""
    plan = plan_step(np.array([0.03, 0.26]), 3.3, FEET, CORNERS, ROTATIONS, SteppingConfig(),
                     0.01)
    assert not plan.capturable


def test_no_crossing_halfplane_and_fallback_target():
    cfg = SteppingConfig()
    # ξ far beyond any single step: no capture region, best effort inside the reach.
    plan = plan_for_swing(LEFT, np.array([2.0, 0.0]), 3.3, FEET, CORNERS[RIGHT], np.eye(3),
                          0.35, cfg, 0.01)
    assert not plan.capturable and plan.region.shape == (0, 2)
    assert np.linalg.norm(plan.target - FEET[RIGHT]) <= cfg.step_length + 1e-9
    assert plan.target[1] - FEET[RIGHT, 1] >= cfg.min_width - 1e-9
