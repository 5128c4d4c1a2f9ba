"""Support polygons, signed distances to them, and the centre of pressure.

The support polygon C is the convex hull of the horizontal projections of the active
contact points. Signed distances follow the reward convention of the spec: negative
inside C (minus the distance to the nearest edge), positive outside (the distance to C).

The hull is Andrew's monotone chain rather than ``scipy.spatial.ConvexHull``: Qhull
raises on 1, 2 or collinear points, which are ordinary support sets here (one foot
edge, a knee point), while the monotone chain returns them as a point or a segment.
"""

from __future__ import annotations

import numpy as np

_EPS = 1e-12


def support_polygon(points: np.ndarray) -> np.ndarray:
    """Convex hull C of the horizontal projections of contact points.

    Args:
        points: Contact points, shape (M, 2) or (M, 3) [m]; z is ignored.

    Returns:
        Hull vertices counter-clockwise, shape (K, 2) [m], without collinear or
        duplicate vertices: K = 1 for a single point, K = 2 (the endpoints) for a
        segment, K ≥ 3 otherwise.

    Raises:
        ValueError: On a wrong shape or no points.
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (M, 2) or (M, 3), got {points.shape}")
    if points.shape[0] == 0:
        raise ValueError("support_polygon needs at least one contact point")
    xy = np.unique(points[:, :2], axis=0)  # sorted by x, then y
    if len(xy) <= 2:
        return xy
    lower = _half_hull(xy)
    upper = _half_hull(xy[::-1])
    return np.array(lower[:-1] + upper[:-1])


def _half_hull(xy: np.ndarray) -> list[np.ndarray]:
    """One monotone-chain pass: keeps only strict left turns."""
    hull: list[np.ndarray] = []
    for p in xy:
        while len(hull) >= 2 and _cross(hull[-1] - hull[-2], p - hull[-2]) <= _EPS:
            hull.pop()
        hull.append(p)
    return hull


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component of the 2-D cross product a × b, over leading dims."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance from p to the segment [a, b], broadcast over leading dims."""
    ab, ap = b - a, p - a
    length2 = np.sum(ab * ab, axis=-1)
    t = np.clip(np.sum(ap * ab, axis=-1) / np.maximum(length2, _EPS), 0.0, 1.0)
    return np.linalg.norm(ap - t[..., None] * ab, axis=-1)


def signed_distance(point: np.ndarray, polygon: np.ndarray) -> float | np.ndarray:
    """Signed distance d of points to a convex polygon.

    d < 0 inside (d = −distance to the nearest edge), d > 0 outside (distance to the
    polygon), d = 0 on the boundary. A point or segment polygon has no inside, so d ≥ 0.

    Args:
        point: Query point(s) p, shape (2,) or (N, 2) [m].
        polygon: Convex polygon C as returned by :func:`support_polygon`
            (counter-clockwise), shape (K, 2) [m], K ≥ 1.

    Returns:
        d, a float for a (2,) point, else shape (N,) [m].
    """
    p = np.asarray(point, dtype=float)
    poly = np.asarray(polygon, dtype=float)
    q = np.atleast_2d(p)[:, None, :]  # (N, 1, 2)
    start, end = poly, np.roll(poly, -1, axis=0)  # edges v_k → v_{k+1}, (K, 2)
    outside = np.min(_segment_distance(q, start, end), axis=-1)
    if len(poly) < 3:
        d = outside
    else:
        edge = end - start
        normal = np.stack([edge[:, 1], -edge[:, 0]], -1) / np.linalg.norm(edge, axis=-1)[:, None]
        # n_k · (p − v_k): ≤ 0 for all k exactly when p ∈ C; its max is −dist(p, ∂C) there.
        inside = np.max(np.sum(normal * (q - start), axis=-1), axis=-1)
        d = np.where(inside > 0.0, outside, inside)
    return float(d[0]) if p.ndim == 1 else d


def signed_distance_batched(
    point: np.ndarray,
    contact_points: np.ndarray,
    mask: np.ndarray,
    no_contact: float = 1.0,
) -> np.ndarray:
    """Signed distance of each env's point to the hull C of its active contacts.

    Exact, and vectorised over envs: a gift-wrapping (Jarvis) march runs in all envs at
    once, at most M steps; each step moves to the point making the smallest
    counter-clockwise turn from the last edge (largest cosine, all points lying left of
    or on the hull edges). Then, as in :func:`signed_distance`, d = max over edges of
    n·(p − a) ≤ 0 inside and d = min over edges of dist(p, [a, b]) outside.
    Inactive points are replaced by the start vertex, which leaves the hull unchanged.
    One point or collinear points have no inside (zero area) and give d ≥ 0.

    Args:
        point: Query points p, shape (N, 2) [m].
        contact_points: Contact points c, shape (N, M, 2) or (N, M, 3) [m]; z ignored.
        mask: Active contacts, shape (N, M) bool.
        no_contact: d given to envs without any active contact [m]. The default 1 m
            (rather than +inf) keeps rewards such as exp(−d²/σ²) and their gradients
            finite; pass ``np.inf`` to mark such envs explicitly.

    Returns:
        d, shape (N,) [m]: negative inside, positive outside.
    """
    p = np.asarray(point, dtype=float)
    c = np.asarray(contact_points, dtype=float)
    mask = np.asarray(mask, dtype=bool)
    n_env, m = mask.shape
    width = int(mask.sum(-1).max()) if n_env else 0
    if m == 0 or width == 0:
        return np.full(n_env, float(no_contact))
    if width < m:  # active points first, then only as many columns as the most active env
        order = np.argsort(~mask, axis=-1, kind="stable")[:, :width]
        c = np.take_along_axis(c[..., :2], order[..., None], 1)
        mask, m = np.take_along_axis(mask, order, 1), width
    # Start at the lowest of the leftmost active points, a hull vertex.
    x = np.where(mask, c[..., 0], np.inf)
    y = np.where(mask & (x == x.min(-1, keepdims=True)), c[..., 1], np.inf)
    first = np.argmin(y, -1)[:, None]
    x0, y0 = np.take_along_axis(c[..., 0], first, -1), np.take_along_axis(c[..., 1], first, -1)
    cx, cy = np.where(mask, c[..., 0], x0), np.where(mask, c[..., 1], y0)

    path_x, path_y = [x0], [y0]
    ux, uy = np.zeros((n_env, 1)), -np.ones((n_env, 1))  # last edge direction
    closed = np.zeros((n_env, 1), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(m):
            dx, dy = cx - path_x[-1], cy - path_y[-1]
            length = np.hypot(dx, dy)
            cos = np.where(length > _EPS, (dx * ux + dy * uy) / length, -2.0)
            k = np.argmax(cos, -1)[:, None]
            nx, ny = np.take_along_axis(cx, k, -1), np.take_along_axis(cy, k, -1)
            sx, sy = nx - path_x[-1], ny - path_y[-1]
            step = np.hypot(sx, sy)
            ux, uy = np.where(step > _EPS, sx / step, ux), np.where(step > _EPS, sy / step, uy)
            nx, ny = np.where(closed, x0, nx), np.where(closed, y0, ny)
            closed |= (nx == x0) & (ny == y0)
            path_x.append(nx)
            path_y.append(ny)
            if closed.all():
                break

    vx, vy = np.concatenate(path_x, -1), np.concatenate(path_y, -1)  # (N, H + 1)
    ax, ay, bx, by = vx[:, :-1], vy[:, :-1], vx[:, 1:], vy[:, 1:]  # edges a → b
    ex, ey = bx - ax, by - ay
    qx, qy = p[:, 0:1] - ax, p[:, 1:2] - ay
    length2 = ex * ex + ey * ey
    t = np.clip((qx * ex + qy * ey) / np.maximum(length2, _EPS**2), 0.0, 1.0)
    outside = np.hypot(qx - t * ex, qy - t * ey).min(-1)
    length = np.sqrt(length2)
    edge_gap = (ey * qx - ex * qy) / np.maximum(length, _EPS)  # n·(p − a), n outward
    inside = np.where(length > _EPS, edge_gap, -np.inf).max(-1)
    # Twice the area swept from the start vertex: zero for a point or a segment.
    area = ((ax - x0) * (by - y0) - (ay - y0) * (bx - x0)).sum(-1)
    d = np.where((area > _EPS) & (inside <= 0.0), inside, outside)
    return np.where(mask.any(-1), d, no_contact)


def zero_moment_point(force: np.ndarray, torque: np.ndarray, height: float = 0.0) -> np.ndarray:
    """Zero-moment point of a net contact wrench on the plane z = h.

    For the wrench (f, τ_O) about the world origin, the point p = (p_x, p_y, h) where
    the horizontal moment τ_O − p × f vanishes is p_x = (h f_x − τ_y) / f_z,
    p_y = (h f_y + τ_x) / f_z.

    Args:
        force: Net contact force f, shape (..., 3) [N], world frame.
        torque: Net contact torque τ_O about the world origin, shape (..., 3) [N·m].
        height: Plane height h [m].

    Returns:
        (p_x, p_y), shape (..., 2) [m].

    Raises:
        ValueError: When some f_z ≤ 0.
    """
    f, tau = np.asarray(force, dtype=float), np.asarray(torque, dtype=float)
    if np.any(f[..., 2] <= 0.0):
        raise ValueError("zero_moment_point: the contacts carry no normal force (f_z <= 0)")
    px = (height * f[..., 0] - tau[..., 1]) / f[..., 2]
    py = (height * f[..., 1] + tau[..., 0]) / f[..., 2]
    return np.stack([px, py], -1)


def center_of_pressure(
    positions: np.ndarray, forces: np.ndarray, height: float = 0.0
) -> np.ndarray:
    """Centre of pressure (ZMP) of point contacts on the plane z = h.

    The net wrench f = Σ f_i, τ_O = Σ p_i × f_i gives the ZMP of
    :func:`zero_moment_point`; for coplanar contacts on z = h it reduces to the
    pressure-weighted mean p = Σ f_z,i p_i / Σ f_z,i.

    Args:
        positions: Contact points p_i, shape (..., M, 3) [m], world frame.
        forces: Contact forces f_i acting on the robot, shape (..., M, 3) [N].
        height: Plane height h [m].

    Returns:
        CoP (x, y), shape (..., 2) [m].

    Raises:
        ValueError: When the total normal force Σ f_z,i ≤ 0.
    """
    pos, f = np.asarray(positions, dtype=float), np.asarray(forces, dtype=float)
    if np.any(np.sum(f[..., 2], axis=-1) <= 0.0):
        raise ValueError("center_of_pressure: the contacts carry no normal force")
    return zero_moment_point(f.sum(-2), np.cross(pos, f).sum(-2), height)
