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
from array_api_compat import array_namespace
from array_api_compat import device as _device

from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.dynamics.compiled import compiled

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
    point: Array,
    contact_points: Array,
    mask: Array,
    no_contact: float = 1.0,
) -> Array:
    """Signed distance of each env's point to the hull C of its active contacts.

    Numpy arrays: exact, per env in one compiled loop (:func:`_signed_distances`): a gift-wrapping
    (Jarvis) march from the lowest of the leftmost active points, each step to the point
    making the smallest counter-clockwise turn from the last edge (largest cosine; the
    first such point on ties). Then, as in :func:`signed_distance`, d = max over edges of
    n·(p − a) ≤ 0 inside and d = min over edges of dist(p, [a, b]) outside. One point or
    collinear points have no inside (zero area) and give d ≥ 0. Torch tensors (any
    device): the same distances with no loop, :func:`signed_distance_enumerated`.

    Args:
        point: Query points p, shape (N, 2) [m].
        contact_points: Contact points c, shape (N, M, 2) or (N, M, 3) [m]; z ignored.
        mask: Active contacts, shape (N, M) bool.
        no_contact: d given to envs without any active contact [m]. The default 1 m
            (rather than +inf) keeps rewards such as exp(−d²/σ²) and their gradients
            finite; pass ``np.inf`` to mark such envs explicitly.

    Returns:
        d, shape (N,) [m]: negative inside, positive outside.

    Raises:
        ValueError: shapes that do not fit together.
    """
    _check_batch(point, contact_points, mask)
    if not isinstance(point, np.ndarray):
        return signed_distance_enumerated(point, contact_points, mask, no_contact)
    p = np.ascontiguousarray(point, dtype=float)
    c = np.ascontiguousarray(contact_points, dtype=float)  # z, if given, is not read
    out = np.empty(mask.shape[0])
    _signed_distances(p, c, np.ascontiguousarray(mask, dtype=bool), float(no_contact), out)
    return out


def _check_batch(point: Array, contact_points: Array, mask: Array) -> None:
    p, c, m = tuple(point.shape), tuple(contact_points.shape), tuple(mask.shape)
    n = m[0] if len(m) == 2 else -1
    if p != (n, 2) or c[:2] != m or len(c) != 3 or c[2] not in (2, 3):
        raise ValueError(f"signed_distance_batched needs point (N, 2), contact_points (N, M, 2|3) "
                         f"and mask (N, M); got {p}, {c}, {m}")


def signed_distance_enumerated(point: Array, contact_points: Array, mask: Array,
                               no_contact: float = 1.0) -> Array:
    """:func:`signed_distance_batched` without a loop, in the array API (torch tensors on
    any device, or numpy): the hull's edges are enumerated rather than marched.

    An ordered pair (i, j) of distinct active points is an edge of C, traversed
    counter-clockwise, when no active point k lies to its right: e × (c_k − c_i) ≥ −ε for
    e = c_j − c_i (ε: 1e-12 m², or 64 ulp of the precision; collinear points give a
    segment's edges both ways). Then, over the edges, d = max n·(p − c_i) ≤ 0 inside
    (n = (e_y, −e_x)/‖e‖, outward), and outside d = min of the distances to the edges and
    to the active points (a point or a segment has no inside). O(N K³) work and memory,
    K the most active contacts of an env in the batch (its active points are moved
    first): for a batch on a GPU, not a loop.

    Args and Returns: as :func:`signed_distance_batched`, in ``point``'s precision.
    """
    _check_batch(point, contact_points, mask)
    xp = array_namespace(point, contact_points, mask)
    qx, qy = contact_points[..., 0], contact_points[..., 1]  # (N, M)
    count = int(xp.max(xp.sum(xp.astype(mask, xp.int32), axis=1))) if mask.shape[0] else 0
    if count == 0:
        return xp.full(point.shape[0], no_contact, dtype=point.dtype, device=_device(point))
    if count < mask.shape[1]:  # each env's active points first: M³ → count³ pairs and sides
        order = xp.argsort(xp.astype(~mask, xp.int8), axis=1, stable=True)[:, :count]
        mask = xp.take_along_axis(mask, order, axis=1)
        qx, qy = xp.take_along_axis(qx, order, axis=1), xp.take_along_axis(qy, order, axis=1)
    ex = qx[:, None, :] - qx[:, :, None]  # e of pair (i, j), (N, M, M)
    ey = qy[:, None, :] - qy[:, :, None]
    # e × (c_k − c_i) = e × c_k − e × c_i, (N, M, M, M)
    side = (ex[..., None] * qy[:, None, None, :] - ey[..., None] * qx[:, None, None, :]
            - (ex * qy[:, :, None] - ey * qx[:, :, None])[..., None])
    tol = max(_EPS, 64 * float(xp.finfo(side.dtype).eps))  # [m²]: float32 rounding
    left = (side >= -tol) | ~mask[:, None, None, :]
    length2 = ex * ex + ey * ey
    pair = mask[:, :, None] & mask[:, None, :]
    edge = pair & xp.all(left, axis=-1) & (length2 > _EPS**2)
    # from p: w = p − c_i, (N, M, 1)
    wx, wy = (point[:, 0:1] - qx)[..., None], (point[:, 1:2] - qy)[..., None]
    length = xp.sqrt(length2)
    normal = (ey * wx - ex * wy) / xp.where(edge, length, 1.0)
    inside = xp.max(xp.where(edge, normal, -xp.inf), axis=(1, 2))
    t = xp.clip((wx * ex + wy * ey) / xp.where(edge, length2, 1.0), 0.0, 1.0)
    t = xp.where(edge, t, 0.0)  # a vertex: the distance to c_i
    gap = xp.sqrt(xp.square(wx - t * ex) + xp.square(wy - t * ey))
    vertex = xp.eye(mask.shape[1], dtype=xp.bool, device=_device(mask))[None] & pair
    outside = xp.min(xp.where(edge | vertex, gap, xp.inf), axis=(1, 2))
    d = xp.where(xp.any(edge, axis=(1, 2)) & (inside <= 0.0), inside, outside)
    return xp.where(xp.any(mask, axis=1), d, no_contact)


@compiled
def _signed_distances(p: np.ndarray, c: np.ndarray, mask: np.ndarray, no_contact: float,
                      out: np.ndarray) -> None:
    """The loop of :func:`signed_distance_batched`: p (N, 2), c (N, M, 2 or 3), mask
    (N, M); writes d into ``out`` (N,)."""
    n, m = mask.shape
    px, py = np.empty(m), np.empty(m)
    vx, vy = np.empty(m + 1), np.empty(m + 1)  # hull path, closed
    for e in range(n):
        k = 0
        for j in range(m):
            if mask[e, j]:
                px[k], py[k] = c[e, j, 0], c[e, j, 1]
                k += 1
        if k == 0:
            out[e] = no_contact
            continue
        first = 0
        for j in range(1, k):
            if px[j] < px[first] or (px[j] == px[first] and py[j] < py[first]):
                first = j
        x0, y0 = px[first], py[first]
        vx[0], vy[0] = x0, y0
        h, ux, uy = 1, 0.0, -1.0  # path length, last edge direction
        for _ in range(k):
            best, pick = -np.inf, 0
            for j in range(k):
                dx, dy = px[j] - vx[h - 1], py[j] - vy[h - 1]
                length = np.hypot(dx, dy)
                cos = (dx * ux + dy * uy) / length if length > _EPS else -2.0
                if cos > best:
                    best, pick = cos, j
            sx, sy = px[pick] - vx[h - 1], py[pick] - vy[h - 1]
            step = np.hypot(sx, sy)
            if step > _EPS:
                ux, uy = sx / step, sy / step
            vx[h], vy[h] = px[pick], py[pick]
            h += 1
            if px[pick] == x0 and py[pick] == y0:
                break
        outside, inside, area = np.inf, -np.inf, 0.0
        for i in range(h - 1):
            ax, ay, bx, by = vx[i], vy[i], vx[i + 1], vy[i + 1]
            ex, ey = bx - ax, by - ay
            qx, qy = p[e, 0] - ax, p[e, 1] - ay
            length2 = ex * ex + ey * ey
            t = min(max((qx * ex + qy * ey) / max(length2, _EPS**2), 0.0), 1.0)
            outside = min(outside, np.hypot(qx - t * ex, qy - t * ey))
            length = np.sqrt(length2)
            if length > _EPS:  # n·(p − a), n outward
                inside = max(inside, (ey * qx - ex * qy) / length)
            area += (ax - x0) * (by - y0) - (ay - y0) * (bx - x0)  # twice the swept area
        out[e] = inside if area > _EPS and inside <= 0.0 else outside


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
