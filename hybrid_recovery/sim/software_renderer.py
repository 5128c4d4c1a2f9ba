"""Frames drawn without OpenGL: MuJoCo's scene geoms projected by its own camera and
filled with matplotlib (Agg), for machines where no OpenGL context can be made.

A drop-in for ``mujoco.Renderer`` (``scene``, ``update_scene``, ``render``, ``close``):
``mjv_updateScene`` runs on the CPU and gives every geom's world pose, size and colour,
and the camera's pose and frustum. Each geom is drawn as the convex hull of its projected
outline points (exact for the convex primitives, the hull of the vertices for meshes),
far to near (painter's order); the floor plane is a grid of 1 m squares. No shading, no
shadows, no reflections: a clear picture of the pose and the balance overlay, ~20–40 ms
per 640 × 480 frame.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure

from hybrid_recovery.dynamics.support import support_polygon

NAME = "software (matplotlib)"
"""How the renderer names itself in the CLIs' output."""
SKY_RGB = (0.16, 0.18, 0.22)
"""Background colour above the horizon."""
FLOOR_RGB = (0.33, 0.36, 0.40)
"""Floor colour; grid lines are drawn lighter."""
GRID_HALF_EXTENT = 12
"""The floor grid covers ±this many 1 m squares around the camera's look-at point."""
FLOOR_HALF_EXTENT = 60.0
"""Half the side of the floor square drawn around the look-at point [m]."""

_G = mujoco.mjtGeom


def _unit_sphere(n: int = 48) -> np.ndarray:
    """n points spread over the unit sphere (Fibonacci lattice), shape (n, 3)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - z * z)
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def _circle(n: int = 20) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    return np.column_stack([np.cos(a), np.sin(a)])


_SPHERE = _unit_sphere()
_CIRCLE = _circle()
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def _local_outline(geom_type: int, size: np.ndarray) -> np.ndarray | None:
    """Points whose convex hull is the primitive, in its own frame, shape (n, 3) [m];
    None for the types drawn otherwise (plane, mesh) or not at all."""
    if geom_type in (_G.mjGEOM_SPHERE, _G.mjGEOM_ELLIPSOID):
        return _SPHERE * size
    if geom_type == _G.mjGEOM_CAPSULE:  # size: radius, radius, half-length
        pts = _SPHERE * size[0]
        pts[:, 2] += np.where(pts[:, 2] >= 0.0, size[2], -size[2])
        return pts
    if geom_type == _G.mjGEOM_CYLINDER:
        ring = _CIRCLE * size[0]
        return np.vstack([np.column_stack([ring, np.full(len(ring), h)])
                          for h in (-size[2], size[2])])
    if geom_type == _G.mjGEOM_BOX:
        return _CORNERS * size
    if geom_type in (_G.mjGEOM_ARROW, _G.mjGEOM_ARROW1, _G.mjGEOM_ARROW2):
        # from the tail (the geom's origin) along +z for size[2]; a head of twice the width
        width, length = size[0], size[2]
        shaft, head = _CIRCLE * width, _CIRCLE * 2.0 * width
        z_head = 0.75 * length
        return np.vstack([np.column_stack([shaft, np.zeros(len(shaft))]),
                          np.column_stack([head, np.full(len(head), z_head)]),
                          [[0.0, 0.0, length]]])
    return None


class SoftwareRenderer:
    """Renders a ``mujoco.MjvScene`` to RGB arrays with matplotlib, no OpenGL.

    Args:
        model: the model to draw.
        height, width: frame size [px].
        max_geom: capacity of the scene (as ``mujoco.Renderer``).
    """

    name = NAME

    def __init__(self, model: mujoco.MjModel, height: int = 240, width: int = 320,
                 max_geom: int = 10000) -> None:
        self.model = model
        self.height, self.width = int(height), int(width)
        self.scene = mujoco.MjvScene(model, maxgeom=max_geom)
        self._option = mujoco.MjvOption()
        self._perturb = mujoco.MjvPerturb()
        self._figure = Figure(figsize=(self.width / 100.0, self.height / 100.0), dpi=100)
        self._canvas = FigureCanvasAgg(self._figure)
        self._axes = self._figure.add_axes((0.0, 0.0, 1.0, 1.0))

    def update_scene(self, data: mujoco.MjData, camera: mujoco.MjvCamera | int | str = -1,
                     scene_option: mujoco.MjvOption | None = None) -> None:
        """Fills the scene from ``data`` as seen by ``camera`` (``mjv_updateScene``)."""
        if not isinstance(camera, mujoco.MjvCamera):
            camera_id = camera if isinstance(camera, int) else mujoco.mj_name2id(
                self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
            free = mujoco.MjvCamera()
            if camera_id == -1:
                mujoco.mjv_defaultFreeCamera(self.model, free)
            else:
                free.type, free.fixedcamid = mujoco.mjtCamera.mjCAMERA_FIXED, camera_id
            camera = free
        mujoco.mjv_updateScene(self.model, data, scene_option or self._option, self._perturb,
                               camera, mujoco.mjtCatBit.mjCAT_ALL, self.scene)

    def render(self) -> np.ndarray:
        """The scene as an RGB image, shape (height, width, 3), uint8."""
        ax = self._axes
        ax.clear()
        ax.set_xlim(0, self.width)
        ax.set_ylim(self.height, 0)
        ax.set_axis_off()
        ax.set_facecolor(SKY_RGB)
        self._figure.set_facecolor(SKY_RGB)
        view = _Camera(self.scene, self.width, self.height)
        polygons: list[tuple[float, np.ndarray, np.ndarray]] = []
        for i in range(self.scene.ngeom):
            geom = self.scene.geoms[i]
            if geom.type == _G.mjGEOM_PLANE:
                self._draw_floor(view)
                continue
            if geom.rgba[3] <= 0.0:
                continue
            points = self._world_outline(geom)
            if points is None:
                continue
            depth = view.depth(np.asarray(geom.pos))
            projected = view.project(points)
            if projected is None or depth <= 0.0:
                continue
            polygons.append((depth, support_polygon(projected), np.array(geom.rgba, float)))
        polygons.sort(key=lambda item: -item[0])
        if polygons:
            faces = [p for _, p, _ in polygons]
            colors = np.array([c for _, _, c in polygons])
            colors[:, 3] = 0.5 + 0.5 * colors[:, 3]  # flat fills read paler than lit ones
            edges = colors.copy()
            edges[:, :3] *= 0.6
            ax.add_collection(PolyCollection(faces, facecolors=colors, edgecolors=edges,
                                             linewidths=0.6, antialiased=True))
        self._canvas.draw()
        image = np.asarray(self._canvas.buffer_rgba())[:, :, :3]
        return np.ascontiguousarray(image[: self.height, : self.width])

    def _world_outline(self, geom: mujoco.MjvGeom) -> np.ndarray | None:
        size = np.asarray(geom.size, float)
        if geom.type == _G.mjGEOM_MESH:
            mesh = geom.dataid // 2  # the scene stores 2·id (+1 for the mesh's hull)
            if not 0 <= mesh < self.model.nmesh:
                return None
            start, count = self.model.mesh_vertadr[mesh], self.model.mesh_vertnum[mesh]
            local = self.model.mesh_vert[start:start + count]
            if len(local) > 400:
                local = local[:: len(local) // 400 + 1]
        else:
            local = _local_outline(int(geom.type), size)
        if local is None or len(local) == 0:
            return None
        rotation = np.asarray(geom.mat, float).reshape(3, 3)
        return np.asarray(local, float) @ rotation.T + np.asarray(geom.pos, float)

    def _draw_floor(self, view: _Camera) -> None:
        ax = self._axes
        cx, cy = np.round(view.lookat_xy)
        f = FLOOR_HALF_EXTENT
        square = np.array([[cx - f, cy - f, 0.0], [cx + f, cy - f, 0.0],
                           [cx + f, cy + f, 0.0], [cx - f, cy + f, 0.0]])
        floor = view.project_clipped(square)
        if floor is not None:
            ax.add_collection(PolyCollection([floor], facecolors=[FLOOR_RGB], edgecolors="none"))
        lines = []
        n = GRID_HALF_EXTENT
        for k in np.arange(-n, n + 1):
            for a, b in (([cx + k, cy - n, 0.0], [cx + k, cy + n, 0.0]),
                         ([cx - n, cy + k, 0.0], [cx + n, cy + k, 0.0])):
                segment = view.project_clipped(np.array([a, b]), closed=False)
                if segment is not None:
                    lines.append(segment)
        grid = tuple(min(1.0, c + 0.12) for c in FLOOR_RGB)
        ax.add_collection(LineCollection(lines, colors=[grid], linewidths=0.8))

    def close(self) -> None:
        self._figure.clear()


class _Camera:
    """The scene's camera (the mean of its two eyes) as a pinhole projection to pixels."""

    def __init__(self, scene: mujoco.MjvScene, width: int, height: int) -> None:
        eyes = [scene.camera[0], scene.camera[1]]
        self.pos = np.mean([np.asarray(c.pos, float) for c in eyes], axis=0)
        forward = np.mean([np.asarray(c.forward, float) for c in eyes], axis=0)
        up = np.mean([np.asarray(c.up, float) for c in eyes], axis=0)
        self.forward = forward / np.linalg.norm(forward)
        self.up = up / np.linalg.norm(up)
        self.right = np.cross(self.forward, self.up)
        cam = scene.camera[0]
        self.near = float(cam.frustum_near)
        self.top, self.bottom = float(cam.frustum_top), float(cam.frustum_bottom)
        half_height = 0.5 * (self.top - self.bottom)
        half_width = (0.5 * float(cam.frustum_width) if cam.frustum_width > 0.0
                      else half_height * width / height)
        self.center = float(cam.frustum_center)
        self.orthographic = bool(cam.orthographic)
        self.scale_x = 0.5 * width / half_width
        self.scale_y = height / (self.top - self.bottom)
        self.width = width
        ahead = self.pos[2] / -self.forward[2] if self.forward[2] < -1e-6 else 3.0
        self.lookat_xy = (self.pos + min(ahead, 20.0) * self.forward)[:2]

    def depth(self, point: np.ndarray) -> float:
        return float((point - self.pos) @ self.forward)

    def _camera_frame(self, points: np.ndarray) -> np.ndarray:
        d = points - self.pos
        return np.column_stack([d @ self.right, d @ self.up, d @ self.forward])

    def _to_pixels(self, cam: np.ndarray) -> np.ndarray:
        scale = 1.0 if self.orthographic else self.near / cam[:, 2]
        x, y = cam[:, 0] * scale, cam[:, 1] * scale
        return np.column_stack([0.5 * self.width + (x - self.center) * self.scale_x,
                                (self.top - y) * self.scale_y])

    def project(self, points: np.ndarray) -> np.ndarray | None:
        """Pixels (u right, v down) of points all in front of the camera, else None."""
        cam = self._camera_frame(points)
        if np.any(cam[:, 2] <= self.near):
            return None
        return self._to_pixels(cam)

    def project_clipped(self, points: np.ndarray, closed: bool = True) -> np.ndarray | None:
        """Pixels of a polygon (or, ``closed=False``, a segment) cut at the near plane."""
        cam = self._camera_frame(points)
        z_min = self.near * 1.01
        kept = []
        count = len(cam) if closed else len(cam) - 1
        for k in range(count):
            a, b = cam[k], cam[(k + 1) % len(cam)]
            if a[2] >= z_min:
                kept.append(a)
            if (a[2] >= z_min) != (b[2] >= z_min):
                t = (z_min - a[2]) / (b[2] - a[2])
                kept.append(a + t * (b - a))
        if not closed and cam[-1][2] >= z_min:
            kept.append(cam[-1])
        if len(kept) < (3 if closed else 2):
            return None
        return self._to_pixels(np.array(kept))
