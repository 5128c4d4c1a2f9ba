"""Capture point and N-step capturability of the linear inverted pendulum (LIP).

Koolen et al. 2012, "Capturability-based analysis and control of legged locomotion,
Part 1", 3D-LIPM with a finite-sized foot. Symbols:

* ω = √(g/h) [1/s], the LIP natural frequency at CoM height h;
* ξ = c + ċ/ω [m], the instantaneous capture point (ICP); with the CoP held at r it
  evolves as ξ(t) = r + (ξ₀ − r) e^{ωt};
* r_max [m] the foot size (largest CoP offset from the ankle), l_max [m] the largest
  step length, Δt_s [s] the shortest step time.
"""

from __future__ import annotations

import numpy as np
from array_api_compat import array_namespace, device

from hybrid_recovery.dynamics.arrays import Array, as_arrays
from hybrid_recovery.dynamics.support import (
    signed_distance,
    signed_distance_batched,
    support_polygon,
)

_MIN_DIST = 1e-8
"""Distance [m] below which ξ counts as on the stance polygon in the capture region."""


def lip_frequency(height: float | np.ndarray, g: float = 9.81) -> float | np.ndarray:
    """LIP natural frequency ω = √(g/h) [1/s] for CoM height h [m] > 0."""
    return np.sqrt(g / np.asarray(height, dtype=float))


def capture_point(
    com_xy: Array,
    com_vel_xy: Array,
    height: float | Array,
    g: float = 9.81,
) -> Array:
    """Instantaneous capture point ξ = c + ċ/ω with ω = √(g/h); numpy arrays (computed in
    float64) or torch tensors (in their own precision, on their device).

    Args:
        com_xy: Horizontal CoM position c, shape (..., 2) [m].
        com_vel_xy: Horizontal CoM velocity ċ, shape (..., 2) [m/s].
        height: CoM height above the ground h, a float or shape (...) [m].
        g: Gravitational acceleration [m/s²].

    Returns:
        ξ, shape (..., 2) [m].

    Raises:
        ValueError: When some h ≤ 0.
    """
    com_xy, com_vel_xy = as_arrays(com_xy, com_vel_xy)
    if not isinstance(height, int | float):
        (height,) = as_arrays(height)
    xp = array_namespace(com_xy, com_vel_xy, height)
    dtype = xp.float64 if isinstance(com_xy, np.ndarray) else com_xy.dtype
    c, v = xp.asarray(com_xy, dtype=dtype), xp.asarray(com_vel_xy, dtype=dtype)
    h = xp.asarray(height, dtype=dtype, device=device(c))
    if bool(xp.any(h <= 0.0)):
        raise ValueError("capture_point: height must be > 0")
    omega = xp.sqrt(g / h[..., None])  # ω = √(g/h)
    return c + v / omega


def zero_step_margin(capture_point: np.ndarray, support_polygon: np.ndarray) -> float | np.ndarray:
    """0-step capturability margin −d(ξ, C): ≥ 0 when ξ lies in the support polygon C.

    Args:
        capture_point: ξ, shape (2,) or (N, 2) [m].
        support_polygon: C, counter-clockwise, shape (K, 2) [m].

    Returns:
        Margin, a float or shape (N,) [m]; the distance from ξ to the nearest edge of C
        when inside, minus the distance to C when outside.
    """
    return -signed_distance(capture_point, support_polygon)


def zero_step_capturable(
    capture_point: np.ndarray, support_polygon: np.ndarray
) -> bool | np.ndarray:
    """Whether ξ ∈ C, so that holding the CoP at ξ brings the LIP to rest (no step)."""
    margin = zero_step_margin(capture_point, support_polygon)
    return bool(margin >= 0.0) if np.ndim(margin) == 0 else margin >= 0.0


def zero_step_margin_batched(
    capture_point: np.ndarray,
    contact_points: np.ndarray,
    mask: np.ndarray,
    no_contact: float = 1.0,
) -> np.ndarray:
    """Per-env 0-step margin −d(ξ, C) over variable contact sets.

    Args:
        capture_point: ξ, shape (N, 2) [m].
        contact_points: Contact points, shape (N, M, 2) or (N, M, 3) [m].
        mask: Active contacts, shape (N, M) bool.
        no_contact: Distance given to envs without contact [m]; their margin is
            −no_contact.

    Returns:
        Margin, shape (N,) [m].
    """
    return -signed_distance_batched(capture_point, contact_points, mask, no_contact)


def zero_step_capturable_batched(
    capture_point: np.ndarray, contact_points: np.ndarray, mask: np.ndarray
) -> np.ndarray:
    """Per-env ξ ∈ C, shape (N,) bool; False for envs without contact."""
    return zero_step_margin_batched(capture_point, contact_points, mask) >= 0.0


def _check_lip(omega: float, step_length: float, foot_size: float, min_step_time: float) -> None:
    if omega <= 0.0:
        raise ValueError("omega must be > 0")
    if step_length < 0.0:
        raise ValueError("step_length must be >= 0")
    if foot_size < 0.0:
        raise ValueError("foot_size must be >= 0")
    if min_step_time < 0.0:
        raise ValueError("min_step_time must be >= 0")


def n_step_capture_distance(
    n: int | np.ndarray,
    *,
    omega: float,
    step_length: float,
    foot_size: float,
    min_step_time: float,
) -> float | np.ndarray:
    """Largest ICP distance d_N to the stance ankle from which N steps can capture.

    With the CoP at the foot edge towards ξ for Δt_s, the distance grows to
    (d − r_max) e^{ωΔt_s} + r_max; a step of l_max then shortens it by l_max, so
    d_N = (d_{N−1} − r_max + l_max) e^{−ωΔt_s} + r_max with d_0 = r_max, i.e.
    d_N = r_max + l_max Σ_{i=1..N} e^{−iωΔt_s}.

    Args:
        n: Number of steps N ≥ 0, int or integer array.
        omega: ω [1/s].
        step_length: l_max [m].
        foot_size: r_max [m].
        min_step_time: Δt_s [s].

    Returns:
        d_N [m], the shape of n.
    """
    _check_lip(omega, step_length, foot_size, min_step_time)
    n = np.asarray(n)
    if np.any(n < 0):
        raise ValueError("n must be >= 0")
    wt = omega * min_step_time
    # Σ_{i=1..N} a^i = (1 − a^N) / (e^{ωΔt_s} − 1), a = e^{−ωΔt_s}; N when Δt_s = 0.
    steps = n * 1.0 if wt == 0.0 else -np.expm1(-n * wt) / np.expm1(wt)
    d = foot_size + step_length * steps
    return float(d) if d.ndim == 0 else d


def capture_margin_limit(
    *, omega: float, step_length: float, foot_size: float, min_step_time: float
) -> float:
    """d_∞ = lim_{N→∞} d_N = r_max + l_max / (e^{ωΔt_s} − 1) [m].

    Beyond d_∞ no number of steps captures the LIP. Infinite when Δt_s = 0 and
    l_max > 0.
    """
    _check_lip(omega, step_length, foot_size, min_step_time)
    if step_length == 0.0:
        return float(foot_size)
    wt = omega * min_step_time
    return float(foot_size + step_length / np.expm1(wt)) if wt > 0.0 else float("inf")


def n_step_capture_margin(
    capture_point_distance: float | np.ndarray,
    n: int | np.ndarray,
    *,
    omega: float,
    step_length: float,
    foot_size: float,
    min_step_time: float,
) -> float | np.ndarray:
    """N-step capturability margin d_N − ‖ξ − r_ankle‖: ≥ 0 when N steps can capture.

    Args:
        capture_point_distance: ‖ξ − r_ankle‖, ICP distance to the stance ankle [m],
            float or any shape broadcastable with n.
        n: Number of steps N ≥ 0.
        omega: ω [1/s].
        step_length: l_max [m].
        foot_size: r_max [m].
        min_step_time: Δt_s [s].

    Returns:
        Margin [m], broadcast shape of the inputs.
    """
    d_n = n_step_capture_distance(
        n,
        omega=omega,
        step_length=step_length,
        foot_size=foot_size,
        min_step_time=min_step_time,
    )
    return d_n - capture_point_distance


def _regular_polygon(center: np.ndarray, radius: float, num_vertices: int) -> np.ndarray:
    """Counter-clockwise num_vertices-gon inscribed in the circle (center, radius)."""
    angle = 2.0 * np.pi * np.arange(num_vertices) / num_vertices
    return center + radius * np.stack([np.cos(angle), np.sin(angle)], -1)


def _centroid(polygon: np.ndarray) -> np.ndarray:
    """Area centroid of a convex polygon (K, 2); the vertex mean when it has no area."""
    nxt = np.roll(polygon, -1, axis=0)
    cross = polygon[:, 0] * nxt[:, 1] - polygon[:, 1] * nxt[:, 0]
    area = 0.5 * cross.sum()
    if len(polygon) < 3 or abs(area) < 1e-12:
        return polygon.mean(axis=0)
    return ((polygon + nxt) * cross[:, None]).sum(axis=0) / (6.0 * area)


def _clip(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland–Hodgman: subject (K, 2) ∩ convex CCW clip (L ≥ 3, 2), vertices (P, 2)."""
    poly = subject
    for a, b in zip(clip, np.roll(clip, -1, axis=0), strict=True):
        if len(poly) == 0:
            break
        nxt = np.roll(poly, -1, axis=0)
        s = (b[0] - a[0]) * (poly[:, 1] - a[1]) - (b[1] - a[1]) * (poly[:, 0] - a[0])
        s_next = np.roll(s, -1)
        inside = s >= 0.0
        crossing = inside != (s_next >= 0.0)
        t = np.where(crossing, s / np.where(crossing, s - s_next, 1.0), 0.0)
        cut = poly + t[:, None] * (nxt - poly)
        poly = np.stack([poly, cut], 1)[np.stack([inside, crossing], 1)]
    return poly


def one_step_capture_region(
    capture_point: np.ndarray,
    stance_foot_polygon: np.ndarray,
    *,
    omega: float,
    step_length: float,
    foot_size: float,
    min_step_time: float,
    num_vertices: int = 32,
    max_step_time: float | None = None,
    foot_center: np.ndarray | None = None,
) -> np.ndarray:
    """Foot placements after which the LIP is 0-step capturable (1-step capture region).

    With the CoP anywhere in the stance polygon S until touchdown at t, the ICP reaches
    T(t) = {r + (ξ₀ − r) e^{ωt} : r ∈ S}, a copy of S reflected through ξ₀ and scaled by
    e^{ωt} − 1. The new ankle must lie within r_max of a point of T(t) and within l_max
    of the stance foot centre. For t ∈ [Δt_s, t_max] the union of T(t) is the convex
    hull of T(Δt_s) ∪ T(t_max), so the region is the convex polygon
    (hull ⊕ disc(r_max)) ∩ disc(l_max), discs taken as inscribed num_vertices-gons
    (a slight under-approximation).

    Args:
        capture_point: ξ₀, shape (2,) [m].
        stance_foot_polygon: S, counter-clockwise, shape (K, 2) [m].
        omega: ω [1/s].
        step_length: l_max [m], > 0.
        foot_size: r_max [m].
        min_step_time: Δt_s [s].
        num_vertices: Vertices of each circle polygon, ≥ 3.
        max_step_time: t_max [s]. None steps at Δt_s exactly (the earliest step);
            ``np.inf`` allows any later step, Koolen's full 1-step capture region.
        foot_center: Centre of the reachable disc [m], shape (2,); the area centroid
            of S by default.

    Returns:
        Region vertices counter-clockwise, shape (P, 2) [m]; shape (0, 2) if empty.
    """
    _check_lip(omega, step_length, foot_size, min_step_time)
    if step_length <= 0.0:
        raise ValueError("step_length must be > 0")
    if num_vertices < 3:
        raise ValueError("num_vertices must be >= 3")
    if max_step_time is not None and max_step_time < min_step_time:
        raise ValueError("max_step_time must be >= min_step_time")
    xi = np.asarray(capture_point, dtype=float)
    stance = np.asarray(stance_foot_polygon, dtype=float)
    center = _centroid(stance) if foot_center is None else np.asarray(foot_center, float)
    away = xi - stance  # ξ₀ − r at the vertices of S
    growth = [np.expm1(omega * min_step_time)]
    if max_step_time is not None and np.isfinite(max_step_time):
        growth.append(np.expm1(omega * max_step_time))
    elif max_step_time is not None:
        # Truncate the union where T(t) lies over `reach` from ξ₀, out of the disc.
        reach = 2.0 * (step_length + foot_size + np.linalg.norm(xi - center)) + 1.0
        gap = max(signed_distance(xi, stance), _MIN_DIST)
        growth.append(max(growth[0], reach / gap))
    touchdown = np.concatenate([xi + g * away for g in growth])
    disc = _regular_polygon(np.zeros(2), foot_size, num_vertices)
    landing = support_polygon((touchdown[:, None] + disc[None]).reshape(-1, 2))
    region = _clip(landing, _regular_polygon(center, step_length, num_vertices))
    return support_polygon(region) if len(region) else np.zeros((0, 2))
