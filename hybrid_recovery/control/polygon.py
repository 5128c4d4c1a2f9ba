"""Small convex-polygon helpers for one point at a time (2-D, counter-clockwise).

Same conventions as :mod:`hybrid_recovery.dynamics.support` (whose vectorised versions
they are checked against), written in plain Python floats: for the ≤ 8-vertex polygons
of one control tick they are ~10× faster than the NumPy versions, which matters at
500 Hz. Polygons are (K, 2) arrays [m], K = 1 (a point) or 2 (a segment) allowed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np


def convex_hull(points: np.ndarray | list[list[float]]) -> np.ndarray:
    """Convex hull (monotone chain) of the xy of points (M, 2|3), CCW, shape (K, 2);
    ``points`` may also be a list of [x, y] pairs (no array round trip)."""
    pairs = points if isinstance(points, list) else np.asarray(points, dtype=float)[:, :2].tolist()
    pts = sorted(set(map(tuple, pairs)))
    if len(pts) <= 2:
        return np.array(pts, dtype=float).reshape(-1, 2)
    return np.array(_half_hull(pts)[:-1] + _half_hull(pts[::-1])[:-1])


def _half_hull(points: list) -> list:
    """One chain of the monotone-chain hull: drops each last point that makes no strict
    left turn (cross product ≤ 1e-12)."""
    hull: list = []
    for point in points:
        px, py = point
        while len(hull) >= 2:
            (ox, oy), (ax, ay) = hull[-2], hull[-1]
            if (ax - ox) * (py - oy) - (ay - oy) * (px - ox) <= 1e-12:
                hull.pop()
            else:
                break
        hull.append(point)
    return hull


def _edges(poly: list) -> zip:
    """(a, b) of each edge of a vertex list, in order, the last one closing the polygon."""
    return zip(poly, poly[1:] + poly[:1], strict=True)


def _edge_distance(px: float, py: float, poly: list) -> float:
    """max over the edges (of length > 1e-12) of p's distance beyond the edge's line,
    −∞ without such edges: ≤ 0 iff p lies in a CCW polygon of ≥ 3 vertices, and then
    −(distance to the nearest edge)."""
    inside = -math.inf
    for (ax, ay), (bx, by) in _edges(poly):
        ex, ey = bx - ax, by - ay
        length = math.hypot(ex, ey)
        if length > 1e-12:
            inside = max(inside, (ey * (px - ax) - ex * (py - ay)) / length)
    return inside


def _nearest(px: float, py: float, poly: list) -> tuple[float, float, float]:
    """Closest point c of the polygon's boundary to p and ‖p − c‖² (the first vertex and ∞
    when no distance is a number): on each edge c = a + t (b − a), t ∈ [0, 1]."""
    best = (poly[0][0], poly[0][1], math.inf)
    for (ax, ay), (bx, by) in _edges(poly):
        ex, ey = bx - ax, by - ay
        length2 = ex * ex + ey * ey
        t = 0.0 if length2 < 1e-18 else min(max(((px - ax) * ex + (py - ay) * ey) / length2,
                                                0.0), 1.0)
        cx, cy = ax + t * ex, ay + t * ey
        dist2 = (px - cx) ** 2 + (py - cy) ** 2
        if dist2 < best[2]:
            best = (cx, cy, dist2)
    return best


def signed_distance_scalar(point: np.ndarray, polygon: np.ndarray) -> float:
    """d(p, C): −(distance to the nearest edge) inside, distance to C outside [m]."""
    px, py = float(point[0]), float(point[1])
    poly = np.asarray(polygon, dtype=float).tolist()
    if len(poly) >= 3:
        inside = _edge_distance(px, py, poly)
        if inside <= 0.0:
            return inside
    return math.sqrt(_nearest(px, py, poly)[2]) if poly else math.inf


def closest_point(point: np.ndarray | Sequence[float], polygon: np.ndarray) -> np.ndarray:
    """argmin_{x ∈ C} ‖x − p‖ (p itself when p ∈ C), shape (2,) [m]."""
    p = np.asarray(point, dtype=float)
    return np.array(closest_xy(float(p[0]), float(p[1]),
                               np.asarray(polygon, dtype=float).tolist()))


def closest_xy(px: float, py: float, verts: list) -> tuple[float, float]:
    """:func:`closest_point` of p = (px, py) in a polygon given as a list of [x, y]."""
    if len(verts) >= 3 and _edge_distance(px, py, verts) <= 0.0:
        return px, py
    cx, cy, _ = _nearest(px, py, verts)
    return cx, cy


def shrink(polygon: np.ndarray, margin: float) -> np.ndarray:
    """Inner parallel polygon, every edge moved inward by ``margin`` ≥ 0 [m].

    Vertices are the intersections of consecutive offset edges. A polygon too small for
    the margin (or without area) collapses to its vertex mean, shape (1, 2).
    """
    poly = np.asarray(polygon, dtype=float)
    if margin <= 0.0:
        return poly.copy()
    return np.array(shrink_vertices(poly.tolist(), margin))


def shrink_vertices(verts: list, margin: float) -> list:
    """:func:`shrink` of a polygon given as a list of [x, y] (K ≥ 1), as a list of
    (x, y) [m]."""
    if margin <= 0.0:
        return list(verts)
    k = len(verts)
    cx, cy = sum(v[0] for v in verts) / k, sum(v[1] for v in verts) / k
    if k < 3:
        return [(cx, cy)]
    lines = []  # edge i: n_i · x = o_i, n_i the outward unit normal
    for (ax, ay), (bx, by) in _edges(verts):
        length = math.hypot(bx - ax, by - ay)
        if length < 1e-12:
            continue
        nx, ny = (by - ay) / length, -(bx - ax) / length
        lines.append((nx, ny, nx * ax + ny * ay - margin))
    out = []
    for i in range(len(lines)):
        n0x, n0y, o0 = lines[i - 1]
        n1x, n1y, o1 = lines[i]
        det = n0x * n1y - n0y * n1x
        if abs(det) < 1e-12:
            return [(cx, cy)]
        out.append(((o0 * n1y - n0y * o1) / det, (n0x * o1 - o0 * n1x) / det))
    for nx, ny, o in lines:  # collapsed: the centre or a vertex outside an offset edge
        if nx * cx + ny * cy > o:
            return [(cx, cy)]
        limit = o + 1e-9
        for x, y in out:
            if nx * x + ny * y > limit:
                return [(cx, cy)]
    return out


def clip_halfplane(polygon: np.ndarray, normal: np.ndarray, offset: float) -> np.ndarray:
    """C ∩ {x : n · x ≤ offset} (Sutherland–Hodgman), CCW, shape (P, 2); (0, 2) if empty."""
    poly = np.asarray(polygon, dtype=float)
    s = poly @ np.asarray(normal, dtype=float) - offset
    out = []
    for k in range(len(poly)):
        j = (k + 1) % len(poly)
        if s[k] <= 0.0:
            out.append(poly[k])
        if (s[k] <= 0.0) != (s[j] <= 0.0):
            out.append(poly[k] + s[k] / (s[k] - s[j]) * (poly[j] - poly[k]))
    return np.array(out) if out else np.zeros((0, 2))
