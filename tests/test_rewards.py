"""Reward terms of the paper (§III-E) on hand-made states with known answers (no simulator)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybrid_recovery.dynamics.capturability import capture_point
from hybrid_recovery.dynamics.support import signed_distance_batched
from hybrid_recovery.envs.config import RewardConfig
from hybrid_recovery.envs.rewards import (
    CAPTURE_POINT_TERMS,
    REWARD_TERMS,
    RewardState,
    action_rate_sq,
    alive,
    capture_point_exp,
    com_support_exp,
    compute_rewards,
    fall_velocity_sq,
    feet_load,
    height_gaussian,
    joint_limit,
    joint_speed,
    momentum_rate_sq,
    orientation_sq,
    rise_velocity,
    stability_band,
    support_contact,
    termination,
    torque_sq,
)

H_STAR = 0.92
DT = 0.02
CFG = RewardConfig()
ALL_ON = dataclasses.replace(CFG, w_feet=2.0, w_joint_speed=1.0)
"""Every term of the table on (the defaults leave r_feet and the joint-speed term off)."""


def state(n: int = 1, **values) -> RewardState:
    """A standing, still robot (every term at its resting value), with ``values`` set."""
    gravity = np.zeros((n, 3))
    gravity[:, 2] = -1.0
    base = dict(
        height=np.full(n, H_STAR), height_vel=np.zeros(n), com_distance=np.full(n, -0.05),
        cp_distance=np.full(n, -0.05), net_force=np.zeros((n, 3)), net_torque=np.zeros((n, 3)),
        torque=np.zeros((n, 27)), limit_violation=np.zeros(n), speed_violation=np.zeros(n),
        action=np.zeros((n, 27)),
        last_action=np.zeros((n, 27)), gravity_b=gravity, support_contacts=np.zeros(n),
        foot_force=np.full((n, 2), 500.0), foot_up=np.ones((n, 2)),
        weight=np.full(n, 1000.0),
        terminated=np.zeros(n, dtype=bool),
    )
    for key, value in values.items():
        base[key] = np.broadcast_to(np.asarray(value, dtype=base[key].dtype),
                                    base[key].shape).copy()
    return RewardState(**base)


# ---------------------------------------------------------------- Group I
def test_height_gaussian_is_one_at_target_and_exp_minus_one_at_sigma():
    s = state(2, height=[H_STAR, H_STAR - CFG.sigma_height])
    np.testing.assert_allclose(height_gaussian(s, CFG, H_STAR), [1.0, np.exp(-1.0)])


def test_rise_pays_alpha_times_rising_speed_below_the_band_only():
    low = H_STAR - 2 * CFG.height_band
    s = state(5, height=[low, low, H_STAR - CFG.height_band / 2, H_STAR + 0.2, low],
              height_vel=[0.5, -0.5, 0.5, 0.5, 0.0])
    np.testing.assert_allclose(rise_velocity(s, CFG, H_STAR),
                               [CFG.alpha_rise * 0.5, 0.0, 0.0, 0.0, 0.0])


def test_fall_costs_squared_falling_speed_outside_the_band():
    s = state(4, height=[0.5, 0.5, H_STAR, H_STAR + 0.2], height_vel=[-1.0, 1.0, -1.0, -0.5])
    r = fall_velocity_sq(s, CFG, H_STAR)
    np.testing.assert_allclose(r, [-CFG.alpha_fall, 0.0, 0.0, -CFG.alpha_fall * 0.25])
    assert r[0] < 0.0


def test_stability_acts_only_inside_the_band():
    inside = H_STAR + CFG.height_band / 2
    s = state(3, height=[inside, inside, H_STAR - 2 * CFG.height_band],
              height_vel=[0.0, 0.25, 0.0])
    np.testing.assert_allclose(stability_band(s, CFG, H_STAR),
                               [CFG.alpha_stab, CFG.alpha_stab - CFG.alpha_stab_vel * 0.25, 0.0])


def test_rise_fall_and_stab_partition_the_height_axis():
    """Outside the band r_stab = 0; inside it r_rise = r_fall = 0 (paper §III-E1)."""
    heights = np.linspace(0.1, 1.3, 241)
    for vel in (-0.7, 0.7):
        s = state(len(heights), height=heights, height_vel=vel)
        inside = np.abs(heights - H_STAR) < CFG.height_band
        assert np.all(rise_velocity(s, CFG, H_STAR)[inside] == 0.0)
        assert np.all(fall_velocity_sq(s, CFG, H_STAR)[inside] == 0.0)
        assert np.all(stability_band(s, CFG, H_STAR)[~inside] == 0.0)


# ---------------------------------------------------------------- Group II
def _feet_points() -> np.ndarray:
    """Two 0.2 × 0.08 m soles, 0.2 m apart: 8 contact points, shape (1, 8, 3)."""
    corners = [(x, y) for x in (-0.05, 0.15) for y in (-0.04, 0.04)]
    left = [(x, y + 0.1, 0.0) for x, y in corners]
    right = [(x, y - 0.1, 0.0) for x, y in corners]
    return np.array([left + right])


def test_capture_point_of_a_still_robot_between_the_feet_gives_r_cp_one():
    points, mask = _feet_points(), np.ones((1, 8), dtype=bool)
    xi = capture_point(np.array([[0.05, 0.0]]), np.zeros((1, 2)), 0.9)
    d = signed_distance_batched(xi, points, mask)
    assert d[0] == pytest.approx(-0.1)  # 0.1 m inside the toe and heel edges
    s = state(cp_distance=d, com_distance=d)
    assert capture_point_exp(s, CFG, H_STAR)[0] == 1.0
    assert com_support_exp(s, CFG, H_STAR)[0] == 1.0


def test_capture_point_sigma_outside_the_toes_gives_exp_minus_one():
    points, mask = _feet_points(), np.ones((1, 8), dtype=bool)
    omega = np.sqrt(9.81 / 0.9)
    # CoM over the ankles moving forward: ξ = c + ċ/ω lands σ_ξ beyond the toe edge (x = 0.15)
    speed = (0.15 + CFG.sigma_cp - 0.05) * omega
    xi = capture_point(np.array([[0.05, 0.0]]), np.array([[speed, 0.0]]), 0.9)
    d = signed_distance_batched(xi, points, mask)
    assert d[0] == pytest.approx(CFG.sigma_cp)
    s = state(cp_distance=d)
    assert capture_point_exp(s, CFG, H_STAR)[0] == pytest.approx(np.exp(-1.0))


def test_com_reward_decays_with_distance_outside_the_support():
    s = state(2, com_distance=[CFG.sigma_com, 2 * CFG.sigma_com])
    np.testing.assert_allclose(com_support_exp(s, CFG, H_STAR), [np.exp(-1.0), np.exp(-4.0)])


def test_momentum_rate_penalty():
    s = state(net_force=[[10.0, 0.0, 0.0]], net_torque=[[0.0, 3.0, 4.0]])
    expected = -(CFG.alpha_lin * 100.0 + CFG.alpha_ang * 25.0)
    assert momentum_rate_sq(s, CFG, H_STAR)[0] == pytest.approx(expected)


def test_hard_landing_costs_about_nine_per_second():
    """The documented scale of α_ℓ: |F_net| ≈ 6.6 kN (Δp ≈ 130 kg·m/s in 20 ms) ≈ 9 / s."""
    s = state(net_force=[[0.0, 0.0, 6600.0]])
    assert -momentum_rate_sq(s, CFG, H_STAR)[0] == pytest.approx(8.7, abs=0.1)


# ---------------------------------------------------------------- Group III
def test_regularisers():
    torque = np.zeros((1, 27))
    torque[0, :2] = (3.0, 4.0)
    action = np.zeros((1, 27))
    action[0, 5] = 0.5
    s = state(torque=torque, limit_violation=[0.1], speed_violation=[0.3], action=action)
    assert torque_sq(s, CFG, H_STAR)[0] == pytest.approx(-25.0)
    assert joint_limit(s, CFG, H_STAR)[0] == pytest.approx(-0.1)
    assert joint_speed(s, CFG, H_STAR)[0] == pytest.approx(-0.3)
    assert action_rate_sq(s, CFG, H_STAR)[0] == pytest.approx(-0.25)
    assert alive(s, CFG, H_STAR)[0] == 1.0


def test_orientation_is_zero_upright_and_minus_one_lying():
    s = state(2, gravity_b=[[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    np.testing.assert_allclose(orientation_sq(s, CFG, H_STAR), [0.0, -1.0])


def test_support_contacts_are_capped_at_two_and_gated_by_height():
    low = CFG.contact_gate_height - 0.1
    s = state(4, height=[low, low, low, CFG.contact_gate_height + 0.1],
              support_contacts=[1.0, 2.0, 4.0, 2.0])
    np.testing.assert_allclose(support_contact(s, CFG, H_STAR), [1.0, 2.0, 2.0, 0.0])


def test_feet_load_is_the_weight_share_on_flat_feet():
    half = 1.0 - (1.0 - CFG.feet_flat) / 2  # u_z half way between u_min and 1
    s = state(5, foot_force=[[500, 500], [300, 0], [500, 500], [900, 900], [400, 400]],
              foot_up=[[1, 1], [1, 1], [CFG.feet_flat, -1], [1, 1], [half, 1]])
    np.testing.assert_allclose(feet_load(s, CFG, H_STAR), [1.0, 0.3, 0.0, 1.0, 0.6])


def test_feet_load_is_off_by_default():
    assert CFG.w_feet == 0.0
    assert "feet" not in compute_rewards(state(), CFG, H_STAR, DT)[1]
    assert compute_rewards(state(), ALL_ON, H_STAR, DT)[1]["feet"][0] == pytest.approx(2.0 * DT)


def test_termination_penalty_only_on_early_termination():
    s = state(2, terminated=[True, False])
    np.testing.assert_allclose(termination(s, CFG, H_STAR), [1.0, 0.0])
    total, parts = compute_rewards(s, CFG, H_STAR, DT)
    assert parts["termination"][0] == pytest.approx(CFG.w_termination * DT) and \
        parts["termination"][0] < 0.0


# ---------------------------------------------------------------- the table and the dt convention
def test_table_names_are_unique_and_weights_exist():
    names = [name for name, _, _ in REWARD_TERMS]
    assert len(names) == len(set(names))
    for _, weight_field, _ in REWARD_TERMS:
        assert isinstance(getattr(CFG, weight_field), float)


def test_value_times_weight_times_dt():
    rng = np.random.default_rng(0)
    s = state(6, height=rng.uniform(0.1, 1.2, 6), height_vel=rng.uniform(-1, 1, 6),
              com_distance=rng.uniform(-0.1, 0.3, 6), cp_distance=rng.uniform(-0.1, 0.3, 6),
              net_force=rng.normal(0, 300, (6, 3)), net_torque=rng.normal(0, 30, (6, 3)),
              torque=rng.normal(0, 30, (6, 27)), action=rng.normal(size=(6, 27)),
              support_contacts=[0, 1, 2, 3, 0, 1], terminated=[0, 1, 0, 0, 1, 0],
              foot_force=rng.uniform(0, 800, (6, 2)), foot_up=rng.uniform(-1, 1, (6, 2)))
    total, parts = compute_rewards(s, ALL_ON, H_STAR, DT)
    assert set(parts) == {name for name, _, _ in REWARD_TERMS}
    for name, weight_field, fn in REWARD_TERMS:
        np.testing.assert_allclose(parts[name],
                                   fn(s, ALL_ON, H_STAR) * getattr(ALL_ON, weight_field) * DT)
        assert parts[name].shape == (6,)
    np.testing.assert_allclose(total, sum(parts.values()))


def test_a_still_upright_robot_earns_a_known_reward_per_second():
    """Standing still at h* with ξ inside the feet: height + stab + com + cp + alive."""
    total, _ = compute_rewards(state(), CFG, H_STAR, dt=1.0)
    expected = CFG.w_height + CFG.w_stab * CFG.alpha_stab + CFG.w_com + CFG.w_cp + CFG.w_alive
    assert total[0] == pytest.approx(expected)


@pytest.mark.parametrize("name,weight_field", [(n, w) for n, w, _ in REWARD_TERMS])
def test_weight_zero_disables_a_term(name, weight_field):
    cfg = dataclasses.replace(ALL_ON, **{weight_field: 0.0})
    s = state(2, height=[0.3, 0.9], height_vel=[-1.0, 0.4], terminated=[True, False],
              cp_distance=[0.2, -0.1], support_contacts=[2, 0])
    total, parts = compute_rewards(s, cfg, H_STAR, DT)
    full_total, full_parts = compute_rewards(s, ALL_ON, H_STAR, DT)
    assert name not in parts
    np.testing.assert_allclose(total, full_total - full_parts[name])


def test_capture_point_ablation_removes_the_com_and_cp_terms():
    cfg = dataclasses.replace(ALL_ON, use_capture_point=False)
    total, parts = compute_rewards(state(), cfg, H_STAR, DT)
    assert set(CAPTURE_POINT_TERMS) == {"com", "cp"}
    assert not set(parts) & {"com", "cp"}
    assert set(parts) == {name for name, _, _ in REWARD_TERMS} - {"com", "cp"}
    full_total, full_parts = compute_rewards(state(), ALL_ON, H_STAR, DT)
    np.testing.assert_allclose(total, full_total - full_parts["com"] - full_parts["cp"])
