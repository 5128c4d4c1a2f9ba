"""Terrain under the robot: flat ground, a slope, rough ground or a step, and its height.

A :class:`Terrain` is parsed from ``flat``, ``slope:DEG[:HEADING]``, ``rough:CM`` or
``step:CM`` (:func:`parse_terrain`); :func:`ground_height` gives the ground's height under
any point, the reference of the success criterion on terrain. The geoms are built by
:mod:`hybrid_recovery.sim.terrain_model`.

* slope: the plane z = tan θ (x cos ψ + y sin ψ) through the origin, rising by θ along the
  heading ψ.
* rough: a height field of ±:data:`FIELD_RADIUS` m, vertices every
  :data:`ROUGH_SPACING` m at heights drawn uniformly and scaled to span exactly [0, h];
  flat z = 0 beyond.
* step: a platform of height h over the half-plane x ≥ 0, its edge through the origin.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Literal

import numpy as np

TerrainKind = Literal["flat", "slope", "rough", "step"]
KINDS: tuple[str, ...] = ("flat", "slope", "rough", "step")

MAX_SLOPE = 45.0
"""Steepest slope accepted [deg]; steeper is a wall, not ground."""
MAX_ROUGH = 20.0
"""Largest rough-ground height accepted [cm]."""
MAX_STEP = 30.0
"""Highest step accepted [cm]."""
FIELD_RADIUS = 5.0
"""Half-width of the rough field and of the step's platform [m]."""
ROUGH_SPACING = 0.2
"""Distance between the rough field's vertices [m]."""
USAGE = "flat, slope:DEG[:HEADING], rough:CM or step:CM"


@dataclass(frozen=True)
class Terrain:
    """One terrain.

    Attributes:
        kind: ``flat``, ``slope``, ``rough`` or ``step``.
        slope: inclination θ [deg] (slope).
        heading: direction ψ in which a slope rises, from the world x axis [deg].
        height: largest height of rough ground, height of the step [m].
        seed: seed of the rough field's heights.
    """

    kind: TerrainKind = "flat"
    slope: float = 0.0
    heading: float = 0.0
    height: float = 0.0
    seed: int = 0

    @property
    def is_flat(self) -> bool:
        """Whether the ground is the plane z = 0 (also slope:0, rough:0, step:0)."""
        return self.kind == "flat" or (self.slope == 0.0 and self.height == 0.0)

    @property
    def text(self) -> str:
        """The terrain as :func:`parse_terrain` reads it, e.g. ``slope:10:90``."""
        if self.kind == "slope":
            return f"slope:{self.slope:g}" + (f":{self.heading:g}" if self.heading else "")
        if self.kind in ("rough", "step"):
            return f"{self.kind}:{self.height * 100:g}"
        return "flat"

    @property
    def difficulty(self) -> float:
        """The terrain's size in its own unit: the slope [deg], the height [cm]; 0 when flat."""
        return abs(self.slope) if self.kind == "slope" else self.height * 100.0


def parse_terrain(text: str) -> Terrain:
    """Reads ``flat``, ``slope:DEG[:HEADING]`` (degrees), ``rough:CM`` or ``step:CM``.

    Raises:
        ValueError: one line naming the text, e.g. ``terrain 'slope:91': the slope must be
            within ±45 deg, got 91``, ``unknown terrain 'mud': use flat, ...``.
    """
    kind, *args = str(text).strip().split(":")
    arity = {"flat": (0, 0), "slope": (1, 2), "rough": (1, 1), "step": (1, 1)}
    if kind not in arity:
        raise ValueError(f"unknown terrain '{text}': use {USAGE}")
    low, high = arity[kind]
    if not low <= len(args) <= high:
        raise ValueError(f"terrain '{text}': use {USAGE}")
    values = []
    for arg in args:
        try:
            value = float(arg)
        except ValueError:
            value = float("nan")
        if not np.isfinite(value):
            raise ValueError(f"terrain '{text}': '{arg}' is not a finite number")
        values.append(value)
    if kind == "slope":
        if abs(values[0]) > MAX_SLOPE:
            raise ValueError(f"terrain '{text}': the slope must be within ±{MAX_SLOPE:g} deg, "
                             f"got {values[0]:g}")
        return Terrain("slope", slope=values[0], heading=values[1] if len(values) > 1 else 0.0)
    if kind in ("rough", "step"):
        most = MAX_ROUGH if kind == "rough" else MAX_STEP
        if not 0.0 <= values[0] <= most:
            raise ValueError(f"terrain '{text}': the height must be 0 to {most:g} cm, "
                             f"got {values[0]:g}")
        return Terrain("rough" if kind == "rough" else "step", height=values[0] / 100.0)
    return Terrain()


def slope_normal(terrain: Terrain) -> np.ndarray:
    """The ground's unit normal n = (−sin θ cos ψ, −sin θ sin ψ, cos θ) of a slope (+z for
    any other terrain), shape (3,)."""
    theta, psi = np.radians(terrain.slope), np.radians(terrain.heading)
    if terrain.kind != "slope":
        theta = 0.0
    return np.array([-np.sin(theta) * np.cos(psi), -np.sin(theta) * np.sin(psi), np.cos(theta)])


@functools.lru_cache(maxsize=32)
def rough_heights(terrain: Terrain) -> np.ndarray:
    """The rough field's vertex heights [m], shape (n, n), row r at y = −R + r·spacing,
    column c at x = −R + c·spacing; min exactly 0, max exactly ``terrain.height``
    (read-only, cached)."""
    n = int(round(2 * FIELD_RADIUS / ROUGH_SPACING)) + 1
    raw = np.random.default_rng(terrain.seed).uniform(size=(n, n))
    heights = (raw - raw.min()) / (raw.max() - raw.min()) * terrain.height
    heights.setflags(write=False)
    return heights


def slope_height(slope: np.ndarray, heading: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Heights of planes rising by ``slope`` [deg] along ``heading`` [deg] through the
    origin under points ``xy`` (..., 2) [m], the angles broadcast against xy[..., 0]."""
    theta, psi = np.radians(slope), np.radians(heading)
    return np.tan(theta) * (xy[..., 0] * np.cos(psi) + xy[..., 1] * np.sin(psi))


def step_height(height: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Heights of steps of ``height`` [m] (platform over x ≥ 0) under points ``xy``."""
    x, y = xy[..., 0], xy[..., 1]
    inside = (x >= 0.0) & (x <= 2 * FIELD_RADIUS) & (np.abs(y) <= FIELD_RADIUS)
    return np.where(inside, height, 0.0)


def ground_height(terrain: Terrain, xy: np.ndarray) -> np.ndarray:
    """The ground's height under points ``xy``, shape (..., 2) [m] → (...) [m].

    Rough ground is MuJoCo's triangulated height field (:func:`_triangles`).
    """
    xy = np.asarray(xy, dtype=float)
    x, y = xy[..., 0], xy[..., 1]
    if terrain.kind == "slope":
        return slope_height(np.asarray(terrain.slope), np.asarray(terrain.heading), xy)
    if terrain.kind == "step":
        return step_height(np.asarray(terrain.height), xy)
    if terrain.kind == "rough" and terrain.height > 0:
        return _triangles(rough_heights(terrain), x, y)
    return np.zeros(np.shape(x))


def highest_ground(terrain: Terrain, xy: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """An upper bound of the ground's height within ``radius`` [m] of points ``xy`` (..., 2)
    (exact for flat ground and slopes, the highest vertex or platform for the others) [m]."""
    xy = np.asarray(xy, dtype=float)
    x, y, r = xy[..., 0], xy[..., 1], np.broadcast_to(radius, np.shape(xy[..., 0]))
    if terrain.kind == "slope":
        return ground_height(terrain, xy) + np.tan(np.radians(abs(terrain.slope))) * r
    if terrain.kind == "step":
        return np.where(x + r >= 0.0, terrain.height, 0.0)
    if terrain.kind == "rough" and terrain.height > 0:
        heights = rough_heights(terrain)
        n = len(heights)
        out = np.zeros(np.shape(x))
        for index in np.ndindex(np.shape(x)):
            lo = np.clip(np.floor((np.array([x[index], y[index]]) - r[index] + FIELD_RADIUS)
                                  / ROUGH_SPACING).astype(int), 0, n - 1)
            hi = np.clip(np.ceil((np.array([x[index], y[index]]) + r[index] + FIELD_RADIUS)
                                 / ROUGH_SPACING).astype(int), 0, n - 1)
            out[index] = heights[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1].max()
        return out
    return np.zeros(np.shape(x))


def _triangles(heights: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """MuJoCo's height-field surface: each cell split along its (r, c)–(r+1, c+1)
    diagonal, linear on each triangle; 0 outside the field."""
    n = len(heights)
    u = (x + FIELD_RADIUS) / ROUGH_SPACING
    v = (y + FIELD_RADIUS) / ROUGH_SPACING
    inside = (u >= 0) & (u <= n - 1) & (v >= 0) & (v <= n - 1)
    c = np.clip(np.floor(u).astype(int), 0, n - 2)
    r = np.clip(np.floor(v).astype(int), 0, n - 2)
    fu, fv = np.clip(u - c, 0, 1), np.clip(v - r, 0, 1)
    h00, h01 = heights[r, c], heights[r, c + 1]
    h10, h11 = heights[r + 1, c], heights[r + 1, c + 1]
    h = np.where(fu >= fv, h00 + fu * (h01 - h00) + fv * (h11 - h01),
                 h00 + fv * (h10 - h00) + fu * (h11 - h10))
    return np.where(inside, h, 0.0)
