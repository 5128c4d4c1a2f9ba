"""Offscreen video of a recovery episode with the balance quantities drawn in the scene.

Drawn as extra primitives after ``mujoco.Renderer.update_scene`` (no meshes, so a frame
costs a few ms on a GPU and 60–100 ms on Mesa's software rasteriser):

* the CoM p_c: a red sphere, with a thin line down to its ground projection;
* the capture point ξ = p_c,xy + ṗ_c,xy / ω: a blue sphere on the ground;
* the support polygons: the hull of the load-bearing foot contacts C_feet (green) and,
  where it differs, the hull of all load-bearing contacts C (yellow), on the ground;
* a push: a red arrow into the torso while it acts.

The overlay is computed from a simulation's own model and data (its randomised masses
and contact parameters); the picture comes from a render model of the same robot with a
textured floor and brighter light. Frames are drawn by MuJoCo's OpenGL renderer where a
context can be made (the backend is chosen before mujoco is imported:
``hybrid_recovery.sim.gl_backend``), else in software
(:class:`hybrid_recovery.sim.software_renderer.SoftwareRenderer`, matplotlib).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.dynamics.capturability import capture_point
from hybrid_recovery.dynamics.support import support_polygon
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import FLOOR_NAME, load_spec
from hybrid_recovery.sim.gl_backend import gl_context_works, loaded_backend
from hybrid_recovery.sim.software_renderer import SoftwareRenderer
from hybrid_recovery.sim.terrain import Terrain
from hybrid_recovery.sim.terrain_model import add_terrain

ROBOT_ALPHA = 0.55
"""Opacity of the robot's geoms in the video."""
MIN_SUPPORT_FORCE = 1.0
"""Normal force above which a contact counts as bearing load [N] (as in the env)."""

_RED = np.array([0.9, 0.15, 0.1, 1.0], np.float32)
_BLUE = np.array([0.15, 0.45, 1.0, 1.0], np.float32)
_GREEN = np.array([0.1, 0.85, 0.3, 1.0], np.float32)
_YELLOW = np.array([1.0, 0.8, 0.1, 0.9], np.float32)
_EYE9 = np.eye(3).ravel()


@dataclass(frozen=True)
class BalanceOverlay:
    """The quantities drawn over one frame, world axes.

    Attributes:
        com: CoM p_c, shape (3,) [m].
        capture_point: ξ, shape (2,) [m].
        feet_polygon: hull of the load-bearing foot contacts, counter-clockwise, (K, 2) [m];
            K = 0 without foot support.
        support_polygon: hull of all load-bearing contacts, (K, 2) [m].
        push_force: force on the torso, shape (3,) [N] (zero without a push).
        push_point: where it acts (the torso's CoM), shape (3,) [m].
    """

    com: np.ndarray
    capture_point: np.ndarray
    feet_polygon: np.ndarray
    support_polygon: np.ndarray
    push_force: np.ndarray
    push_point: np.ndarray


def balance_overlay(model: mujoco.MjModel, data: mujoco.MjData,
                    push_force: np.ndarray | None = None) -> BalanceOverlay:
    """CoM, capture point and support polygons of a robot state.

    Runs ``mj_forward`` (and ``mj_subtreeVel``) on ``data``, so that the contacts and
    their forces belong to its current state; the state itself is not changed.

    Args:
        model: the simulation's model (root body 1, a floor named ``floor``).
        data: its data.
        push_force: world force on the torso [N], shape (3,), or None.

    Returns:
        The overlay.
    """
    mujoco.mj_forward(model, data)
    mujoco.mj_subtreeVel(model, data)
    com = data.subtree_com[1].copy()
    vel = data.subtree_linvel[1]
    xi = capture_point(com[:2], vel[:2], max(float(com[2]), 1e-3), g=GRAVITY)
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, FLOOR_NAME)
    feet = {mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in constants.FOOT_BODIES}
    force = np.zeros(6)
    all_points, foot_points = [], []
    for i in range(data.ncon):
        contact = data.contact[i]
        if floor not in (contact.geom1, contact.geom2):
            continue
        mujoco.mj_contactForce(model, data, i, force)
        if force[0] <= MIN_SUPPORT_FORCE:
            continue
        other = contact.geom2 if contact.geom1 == floor else contact.geom1
        all_points.append(contact.pos[:2].copy())
        if model.geom_bodyid[other] in feet:
            foot_points.append(contact.pos[:2].copy())
    torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, constants.TORSO_BODY)
    return BalanceOverlay(
        com=com, capture_point=np.asarray(xi, dtype=float),
        feet_polygon=_hull(foot_points), support_polygon=_hull(all_points),
        push_force=np.zeros(3) if push_force is None else np.asarray(push_force, float),
        push_point=data.xipos[torso].copy(),
    )


def _hull(points: list[np.ndarray]) -> np.ndarray:
    return support_polygon(np.array(points)) if points else np.zeros((0, 2))


def add_overlay(scene: mujoco.MjvScene, overlay: BalanceOverlay) -> int:
    """Appends the overlay's primitives to ``scene`` (after ``mjv_updateScene``).

    Returns:
        The number of geoms added (fewer if the scene is full).
    """
    start = scene.ngeom
    com, xi = overlay.com, overlay.capture_point
    ground = np.array([com[0], com[1], 0.005])
    _sphere(scene, com, 0.045, _RED)
    _segment(scene, com, ground, 0.006, _RED)
    _sphere(scene, np.array([xi[0], xi[1], 0.02]), 0.035, _BLUE)
    _polygon(scene, overlay.feet_polygon, 0.004, 0.009, _GREEN)
    if not _same_polygon(overlay.support_polygon, overlay.feet_polygon):
        _polygon(scene, overlay.support_polygon, 0.007, 0.006, _YELLOW)
    magnitude = float(np.linalg.norm(overlay.push_force))
    if magnitude > 0.0:
        tail = overlay.push_point - overlay.push_force / magnitude * (0.3 + magnitude / 600.0)
        _connector(scene, mujoco.mjtGeom.mjGEOM_ARROW, tail, overlay.push_point, 0.03, _RED)
    return scene.ngeom - start


def _same_polygon(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.allclose(a, b)


def _next_geom(scene: mujoco.MjvScene) -> mujoco.MjvGeom | None:
    if scene.ngeom >= scene.maxgeom:
        return None
    geom = scene.geoms[scene.ngeom]
    scene.ngeom += 1
    return geom


def _sphere(scene: mujoco.MjvScene, pos: np.ndarray, radius: float, rgba: np.ndarray) -> None:
    geom = _next_geom(scene)
    if geom is not None:
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_SPHERE, np.full(3, radius),
                            np.asarray(pos, float), _EYE9, rgba)
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        geom.emission = 0.4


def _connector(scene: mujoco.MjvScene, kind: int, a: np.ndarray, b: np.ndarray, width: float,
               rgba: np.ndarray) -> None:
    geom = _next_geom(scene)
    if geom is not None:
        mujoco.mjv_initGeom(geom, kind, np.zeros(3), np.zeros(3), _EYE9, rgba)
        mujoco.mjv_connector(geom, kind, width, np.asarray(a, float), np.asarray(b, float))
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        geom.emission = 0.4


def _segment(scene: mujoco.MjvScene, a: np.ndarray, b: np.ndarray, width: float,
             rgba: np.ndarray) -> None:
    _connector(scene, mujoco.mjtGeom.mjGEOM_CAPSULE, a, b, width, rgba)


def _polygon(scene: mujoco.MjvScene, polygon: np.ndarray, height: float, width: float,
             rgba: np.ndarray) -> None:
    """Closed outline on the ground: K edges (K ≥ 3), one segment (K = 2) or a dot (K = 1)."""
    pts = np.column_stack([polygon, np.full(len(polygon), height)]) if len(polygon) else polygon
    if len(pts) == 1:
        _sphere(scene, pts[0], 2 * width, rgba)
    elif len(pts) == 2:
        _segment(scene, pts[0], pts[1], width, rgba)
    else:
        for k in range(len(pts)):
            _segment(scene, pts[k], pts[(k + 1) % len(pts)], width, rgba)


def render_model(model_path: str | Path | None = None, width: int = 640,
                 height: int = 480, terrain: Terrain | None = None) -> mujoco.MjModel:
    """The robot (translucent) with a checkered floor (or ``terrain``), a brighter headlight
    and an offscreen buffer of at least ``width`` × ``height``; its qpos layout is the env's."""
    spec = load_spec(model_path, floor=True, actuators=True)
    add_terrain(spec, terrain or Terrain())
    spec.add_texture(name="hr_grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.28, 0.31, 0.35],
                     rgb2=[0.38, 0.41, 0.45], width=300, height=300,
                     mark=mujoco.mjtMark.mjMARK_EDGE, markrgb=[0.55, 0.55, 0.55])
    spec.add_material(name="hr_grid", textures=["", "hr_grid"], texrepeat=[1.0, 1.0],
                      texuniform=True)
    spec.geom(FLOOR_NAME).material = "hr_grid"
    light = spec.visual.headlight
    light.ambient, light.diffuse, light.specular = [0.4] * 3, [0.7] * 3, [0.1] * 3
    spec.visual.global_.offwidth = max(int(width), int(spec.visual.global_.offwidth))
    spec.visual.global_.offheight = max(int(height), int(spec.visual.global_.offheight))
    model = spec.compile()
    robot = model.geom_bodyid > 0
    model.geom_rgba[robot, 3] = ROBOT_ALPHA  # see the CoM inside the body
    model.geom_matid[robot] = -1
    return model


BACKENDS = ("auto", "opengl", "software")
"""Renderer choices: ``auto`` uses OpenGL where a context can be made, else software."""

_gl_failed = False  # set when an OpenGL context failed in this process despite the probe


def renderer_backend() -> str:
    """What ``BalanceRenderer(backend="auto")`` draws with in this process, in words."""
    if gl_context_works() and not _gl_failed:
        return f"OpenGL (MUJOCO_GL={loaded_backend() or 'default'})"
    return SoftwareRenderer.name


class BalanceRenderer:
    """Offscreen frames of a robot state with its balance overlay, the camera following
    the CoM (exponentially smoothed, time constant ``follow_time``).

    Args:
        model_path: the robot's MJCF (None: the project's H1-2), as simulated.
        width, height: frame size [px].
        distance: camera distance [m]; azimuth, elevation: view angles [deg].
        follow_time: smoothing time constant of the tracking [s].
        backend: ``"auto"`` (OpenGL if a context can be made, else software),
            ``"opengl"`` or ``"software"``.

    Attributes:
        backend_name: what draws the frames, in words (``renderer_backend()``).

    Raises:
        ValueError: an unknown ``backend``.
        RuntimeError: ``backend="opengl"`` and no OpenGL context could be made.
    """

    def __init__(self, model_path: str | Path | None = None, width: int = 640,
                 height: int = 480, distance: float = 3.2, azimuth: float = 135.0,
                 elevation: float = -15.0, follow_time: float = 0.3,
                 backend: str = "auto", terrain: Terrain | None = None) -> None:
        global _gl_failed
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {list(BACKENDS)}, got {backend!r}")
        self.model = render_model(model_path, width, height, terrain)
        self.data = mujoco.MjData(self.model)
        use_gl = backend == "opengl" or (backend == "auto" and gl_context_works()
                                         and not _gl_failed)
        self.renderer: mujoco.Renderer | SoftwareRenderer
        if use_gl:
            try:
                self.renderer = mujoco.Renderer(self.model, height, width)
                self.backend_name = f"OpenGL (MUJOCO_GL={loaded_backend() or 'default'})"
            except Exception as err:  # the GL backends raise several types
                if backend == "opengl":
                    raise RuntimeError(
                        f"cannot create an OpenGL context for offscreen rendering (MUJOCO_GL="
                        f"{loaded_backend()!r}): {err}. Set MUJOCO_GL=egl (or "
                        "osmesa) before Python imports mujoco.") from err
                _gl_failed = True
                use_gl = False
        if not use_gl:
            self.renderer = SoftwareRenderer(self.model, height, width)
            self.backend_name = SoftwareRenderer.name
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.distance, self.camera.azimuth = distance, azimuth
        self.camera.elevation = elevation
        self.follow_time = follow_time
        self._lookat: np.ndarray | None = None

    def frame(self, qpos: np.ndarray, overlay: BalanceOverlay, dt: float) -> np.ndarray:
        """One frame of the robot at ``qpos`` with ``overlay``; ``dt`` [s] since the last.

        Returns:
            RGB image, shape (height, width, 3), uint8.
        """
        self.data.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        target = np.array([overlay.com[0], overlay.com[1], max(0.45, overlay.com[2] - 0.25)])
        if self._lookat is None:
            self._lookat = target
        else:
            self._lookat += (1.0 - math.exp(-dt / self.follow_time)) * (target - self._lookat)
        self.camera.lookat[:] = self._lookat
        self.renderer.update_scene(self.data, self.camera)
        add_overlay(self.renderer.scene, overlay)
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()
