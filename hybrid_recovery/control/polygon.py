"""Small convex-polygon helpers for one point at a time (2-D, counter-clockwise).

Same conventions as :mod:`hybrid_recovery.dynamics.support` (whose vectorised versions
they are checked against), written in plain Python floats: for the ≤ 8-vertex polygons
of one control tick they are ~10× faster than the NumPy versions, which matters at
500 Hz. Polygons are (K, 2) arrays [m], K = 1 (a point) or 2 (a segment) allowed.
"""

from __future__ import annotations

import math

import numpy as np


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull (monotone chain) of the xy of points (M, 2|3), CCW, shape (K, 2)."""
    pts = sorted(set(map(tuple, np.asarray(points, dtype=float)[:, :2].tolist())))
    if len(pts) <= 2:
        return np.array(pts, dtype=float).reshape(-1, 2)

    def half(seq):
        hull: list = []
        for p in seq:
            while len(hull) >= 2 and ((hull[-1][0] - hull[-2][0]) * (p[1] - hull[-2][1]) - (
                    hull[-1][1] - hull[-2][1]) * (p[0] - hull[-2][0])) <= 1e-12:
                hull.pop()
            hull.append(p)
        return hull

    return np.array(half(pts)[:-1] + half(pts[::-1])[:-1])


def _segment(px: float, py: float, ax: float, ay: float, bx: float, by: float):
    """Closest point of [a, b] to p and its squared distance."""
    ex, ey = bx - ax, by - ay
    length2 = ex * ex + ey * ey
    t = 0.0 if length2 < 1e-18 else min(max(((px - ax) * ex + (py - ay) * ey) / length2, 0.0),
                                        1.0)
    cx, cy = ax + t * ex, ay + t * ey
    return cx, cy, (px - cx) ** 2 + (py - cy) ** 2


def signed_distance_scalar(point: np.ndarray, polygon: np.ndarray) -> float:
    """d(p, C): −(distance to the nearest edge) inside, distance to C outside [m]."""
    px, py = float(point[0]), float(point[1])
    poly = np.asarray(polygon, dtype=float).tolist()
    k = len(poly)
    best = math.inf
    inside = -math.inf
    for i in range(k):
        ax, ay = poly[i]
        bx, by = poly[(i + 1) % k]
        best = min(best, _segment(px, py, ax, ay, bx, by)[2])
        length = math.hypot(bx - ax, by - ay)
        if length > 1e-12:
            inside = max(inside, ((by - ay) * (px - ax) - (bx - ax) * (py - ay)) / length)
    if k >= 3 and inside <= 0.0:
        return inside
    return math.sqrt(best)


def closest_point(point: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """argmin_{x ∈ C} ‖x − p‖ (p itself when p ∈ C), shape (2,) [m]."""
    p = np.asarray(point, dtype=float)
    poly = np.asarray(polygon, dtype=float)
    if len(poly) >= 3 and signed_distance_scalar(p, poly) <= 0.0:
        return p.copy()
    px, py = float(p[0]), float(p[1])
    verts = poly.tolist()
    best = (verts[0][0], verts[0][1], math.inf)
    for i in range(len(verts)):
        cand = _segment(px, py, *verts[i], *verts[(i + 1) % len(verts)])
        if cand[2] < best[2]:
            best = cand
    return np.array(best[:2])


def shrink(polygon: np.ndarray, margin: float) -> np.ndarray:
    """Inner parallel polygon, every edge moved inward by ``margin`` ≥ 0 [m].

    Vertices are the intersections of consecutive offset edges. A polygon too small for
    the margin (or without area) collapses to its vertex mean, shape (1, 2).
    """
    poly = np.asarray(polygon, dtype=float)
    if margin <= 0.0:
        return poly.copy()
    verts = poly.tolist()
    k = len(verts)
    cx, cy = sum(v[0] for v in verts) / k, sum(v[1] for v in verts) / k
    if k < 3:
        return np.array([[cx, cy]])
    lines = []  # edge i: n_i · x = o_i, n_i the outward unit normal
    for i in range(k):
        (ax, ay), (bx, by) = verts[i], verts[(i + 1) % k]
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
            return np.array([[cx, cy]])
        out.append(((o0 * n1y - n0y * o1) / det, (n0x * o1 - o0 * n1x) / det))
    for nx, ny, o in lines:  # collapsed: the centre or a vertex outside an offset edge
        if nx * cx + ny * cy > o or any(nx * x + ny * y > o + 1e-9 for x, y in out):
            return np.array([[cx, cy]])
    return np.array(out)


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
