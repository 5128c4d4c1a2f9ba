"""Capture point and capturability against the LIP's closed form and brute-force simulation."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.dynamics.capturability import (
    capture_margin_limit,
    capture_point,
    lip_frequency,
    n_step_capture_distance,
    n_step_capture_margin,
    one_step_capture_region,
    zero_step_capturable,
    zero_step_capturable_batched,
    zero_step_margin,
    zero_step_margin_batched,
)
from hybrid_recovery.dynamics.support import signed_distance

HEIGHT = 1.0
OMEGA = float(lip_frequency(HEIGHT))
LIP = dict(omega=OMEGA, step_length=0.5, foot_size=0.1, min_step_time=0.3)
FOOT = np.array([[-0.1, -0.05], [0.15, -0.05], [0.15, 0.05], [-0.1, 0.05]])
DT = 1e-3


def _lip_rk4(c: np.ndarray, v: np.ndarray, cop: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One RK4 step of c̈ = ω²(c − p) with the CoP p held fixed."""

    def f(c_: np.ndarray, v_: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return v_, OMEGA**2 * (c_ - cop)

    k1 = f(c, v)
    k2 = f(c + 0.5 * DT * k1[0], v + 0.5 * DT * k1[1])
    k3 = f(c + 0.5 * DT * k2[0], v + 0.5 * DT * k2[1])
    k4 = f(c + DT * k3[0], v + DT * k3[1])
    c = c + DT / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
    v = v + DT / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return c, v


def test_capture_point_of_a_static_robot_is_the_com_projection() -> None:
    com = np.array([[0.1, -0.2], [0.3, 0.4]])
    np.testing.assert_allclose(capture_point(com, np.zeros((2, 2)), np.array([0.9, 1.1])), com)


def test_capture_point_formula_and_batching() -> None:
    rng = np.random.default_rng(0)
    com, vel = rng.normal(size=(4, 3, 2)), rng.normal(size=(4, 3, 2))
    height = rng.uniform(0.5, 1.2, size=(4, 3))
    xi = capture_point(com, vel, height, g=9.81)
    np.testing.assert_allclose(xi, com + vel * np.sqrt(height / 9.81)[..., None])
    np.testing.assert_allclose(capture_point(com, vel, 1.0), com + vel / np.sqrt(9.81))
    with pytest.raises(ValueError, match="^capture_point: height must be > 0$"):
        capture_point(com, vel, np.zeros((4, 3)))


def test_lip_started_at_its_capture_point_comes_to_rest_over_the_cop() -> None:
    cop = np.array([0.05, -0.02])
    c, v = np.array([-0.2, 0.1]), np.array([0.0, 0.0])
    v = OMEGA * (cop - c)  # ξ = c + ċ/ω = p
    np.testing.assert_allclose(capture_point(c, v, HEIGHT), cop)
    for _ in range(int(4.0 / DT)):
        c, v = _lip_rk4(c, v, cop)
    np.testing.assert_allclose(c, cop, atol=1e-4)
    np.testing.assert_allclose(v, 0.0, atol=1e-4)


def test_icp_diverges_from_the_cop_as_the_closed_form_says() -> None:
    cop = np.zeros(2)
    c, v = np.array([0.02, 0.0]), np.array([0.3, 0.1])
    xi0 = capture_point(c, v, HEIGHT)
    for _ in range(int(1.0 / DT)):
        c, v = _lip_rk4(c, v, cop)
    np.testing.assert_allclose(capture_point(c, v, HEIGHT), xi0 * np.exp(OMEGA * 1.0), rtol=1e-9)
    assert not zero_step_capturable(xi0, FOOT - [0.5, 0.0])
    assert np.linalg.norm(c) > 1.0


def test_zero_step_margin_on_a_foot() -> None:
    assert zero_step_margin(np.array([0.0, 0.0]), FOOT) == pytest.approx(0.05)
    assert zero_step_margin(np.array([0.35, 0.05]), FOOT) == pytest.approx(-0.2)
    assert zero_step_capturable(np.array([0.15, 0.0]), FOOT) is True
    assert zero_step_capturable(np.array([0.1501, 0.0]), FOOT) is False
    np.testing.assert_array_equal(
        zero_step_capturable(np.array([[0.0, 0.0], [1.0, 0.0]]), FOOT), [True, False]
    )


def test_zero_step_batched_matches_scalar() -> None:
    rng = np.random.default_rng(1)
    xi = rng.uniform(-0.3, 0.3, size=(50, 2))
    contacts = np.broadcast_to(FOOT, (50, 4, 2))
    mask = np.ones((50, 4), dtype=bool)
    mask[0] = False
    margin = zero_step_margin_batched(xi, contacts, mask)
    np.testing.assert_allclose(margin[1:], zero_step_margin(xi[1:], FOOT))
    assert margin[0] == -1.0
    capturable = zero_step_capturable_batched(xi, contacts, mask)
    np.testing.assert_array_equal(capturable, margin >= 0.0)
    assert not capturable[0]


def test_n_step_distance_follows_the_recursion() -> None:
    r, l_max = LIP["foot_size"], LIP["step_length"]
    a = np.exp(-OMEGA * LIP["min_step_time"])
    d = r
    for n in range(12):
        assert n_step_capture_distance(n, **LIP) == pytest.approx(d, rel=1e-12)
        d = (d - r + l_max) * a + r
    d_n = n_step_capture_distance(np.arange(20), **LIP)
    d_inf = capture_margin_limit(**LIP)
    assert d_n[0] == r
    assert np.all(np.diff(d_n) > 0.0) and np.all(d_n < d_inf)
    assert n_step_capture_distance(60, **LIP) == pytest.approx(d_inf, rel=1e-15)
    assert d_inf == pytest.approx(r + l_max * a / (1.0 - a))


def test_n_step_distance_limits() -> None:
    no_time = dict(LIP, min_step_time=0.0)
    assert n_step_capture_distance(3, **no_time) == pytest.approx(0.1 + 3 * 0.5)
    assert capture_margin_limit(**no_time) == np.inf
    assert capture_margin_limit(**dict(LIP, step_length=0.0)) == 0.1
    margin = n_step_capture_margin(np.array([0.05, 0.3]), 1, **LIP)
    np.testing.assert_allclose(margin, n_step_capture_distance(1, **LIP) - np.array([0.05, 0.3]))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(LIP, omega=0.0), "omega must be > 0"),
        (dict(LIP, step_length=-0.1), "step_length must be >= 0"),
        (dict(LIP, foot_size=-0.1), "foot_size must be >= 0"),
        (dict(LIP, min_step_time=-0.1), "min_step_time must be >= 0"),
    ],
)
def test_n_step_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}$"):
        n_step_capture_distance(1, **kwargs)
    with pytest.raises(ValueError, match=f"^{message}$"):
        capture_margin_limit(**kwargs)
    with pytest.raises(ValueError, match="^n must be >= 0$"):
        n_step_capture_distance(-1, **LIP)


def _captured_by_stepping(distance: float, n_steps: int, first_step_time: float) -> bool:
    """1-D LIP: CoP at the foot edge towards ξ, steps of ≤ l_max towards ξ, then balance."""
    r, l_max, t_s = LIP["foot_size"], LIP["step_length"], LIP["min_step_time"]
    ankle, c = np.zeros(1), np.zeros(1)
    v = OMEGA * np.array([distance])  # ξ₀ = c + ċ/ω at `distance` from the ankle
    step_times = first_step_time + t_s * np.arange(n_steps)
    t = 0.0
    for k in range(int((step_times[-1] if n_steps else 0.0) / DT + 2.5 / DT)):
        xi = c + v / OMEGA
        if np.any(np.isclose(t, step_times, atol=DT / 2)):
            ankle = ankle + np.clip(xi - ankle, -l_max, l_max)
        cop = ankle + np.clip(xi - ankle, -r, r)
        c, v = _lip_rk4(c, v, cop)
        t = (k + 1) * DT
    return bool(abs(v[0]) < 0.01 and abs(c[0] - ankle[0]) <= r + 1e-6)


@pytest.mark.parametrize("n_steps", [0, 1, 2, 3])
def test_n_step_distance_is_the_brute_force_capture_boundary(n_steps: int) -> None:
    d_n = n_step_capture_distance(n_steps, **LIP)
    assert _captured_by_stepping(d_n - 2e-3, n_steps, LIP["min_step_time"])
    assert not _captured_by_stepping(d_n + 2e-3, n_steps, LIP["min_step_time"])


def test_stepping_later_does_not_beat_d1() -> None:
    d_1 = n_step_capture_distance(1, **LIP)
    for delay in (0.05, 0.15):
        assert not _captured_by_stepping(d_1 + 2e-3, 1, LIP["min_step_time"] + delay)


def _brute_force_region_margin(
    xi: np.ndarray, queries: np.ndarray, step_times: np.ndarray
) -> np.ndarray:
    """Capture margin of foot placements, min over sampled step times t.

    At touchdown the ICP can be anywhere in T(t) = {r + (ξ₀ − r) e^{ωt} : r ∈ FOOT}; the
    new ankle must be within r_max of T(t) and within l_max of the stance foot centre.
    """
    near = np.full(len(queries), np.inf)
    for t in step_times:
        touchdown = FOOT + (xi - FOOT) * np.exp(OMEGA * t)  # FOOT turned by π: still CCW
        near = np.minimum(near, np.maximum(signed_distance(queries, touchdown), 0.0))
    reach = np.linalg.norm(queries - FOOT.mean(axis=0), axis=-1)
    return np.minimum(LIP["foot_size"] - near, LIP["step_length"] - reach)


@pytest.mark.parametrize(
    ("xi", "max_step_time", "step_times"),
    [
        (np.array([0.3, 0.1]), None, np.array([0.3])),
        (np.array([0.05, 0.02]), None, np.array([0.3])),
        (np.array([0.3, 0.1]), 0.5, np.linspace(0.3, 0.5, 201)),
        (np.array([0.2, -0.15]), np.inf, np.linspace(0.3, 1.2, 2001)),
    ],
)
def test_one_step_region_matches_brute_force(
    xi: np.ndarray, max_step_time: float | None, step_times: np.ndarray
) -> None:
    region = one_step_capture_region(xi, FOOT, **LIP, num_vertices=64, max_step_time=max_step_time)
    assert region.shape[0] >= 3
    rng = np.random.default_rng(2)
    queries = rng.uniform(region.min(axis=0) - 0.05, region.max(axis=0) + 0.05, size=(3000, 2))
    truth = _brute_force_region_margin(xi, queries, step_times)
    inside = signed_distance(queries, region) <= 0.0
    clear = np.abs(truth) > 6e-3  # circle polygons and CoP sampling blur the boundary
    np.testing.assert_array_equal(inside[clear], truth[clear] > 0.0)
    assert inside[clear].sum() > 200 and (~inside[clear]).sum() > 200


def test_one_step_region_is_nonempty_exactly_within_d1() -> None:
    """A round foot of radius r_max reaching l_max from its ankle: nonempty iff ‖ξ‖ ≤ d_1."""
    angle = 2 * np.pi * np.arange(128) / 128
    round_foot = LIP["foot_size"] * np.column_stack([np.cos(angle), np.sin(angle)])
    d_1 = n_step_capture_distance(1, **LIP)
    for direction in (np.array([1.0, 0.0]), np.array([0.6, -0.8])):
        near = one_step_capture_region(
            (d_1 - 0.01) * direction, round_foot, **LIP, num_vertices=128
        )
        far = one_step_capture_region((d_1 + 0.01) * direction, round_foot, **LIP, num_vertices=128)
        assert len(near) >= 3
        assert far.shape == (0, 2)


def test_one_step_region_full_contains_earliest() -> None:
    xi = np.array([0.25, 0.05])
    earliest = one_step_capture_region(xi, FOOT, **LIP)
    full = one_step_capture_region(xi, FOOT, **LIP, max_step_time=np.inf)
    assert np.all(signed_distance(earliest, full) <= 1e-9)
    inside_foot = one_step_capture_region(np.zeros(2), FOOT, **LIP, max_step_time=np.inf)
    assert abs(signed_distance(FOOT.mean(axis=0), inside_foot) + 0.5) < 0.01  # the reach disc


def test_one_step_region_errors() -> None:
    xi = np.zeros(2)
    with pytest.raises(ValueError, match="^step_length must be > 0$"):
        one_step_capture_region(xi, FOOT, **dict(LIP, step_length=0.0))
    with pytest.raises(ValueError, match="^num_vertices must be >= 3$"):
        one_step_capture_region(xi, FOOT, **LIP, num_vertices=2)
    with pytest.raises(ValueError, match="^max_step_time must be >= min_step_time$"):
        one_step_capture_region(xi, FOOT, **LIP, max_step_time=0.1)
