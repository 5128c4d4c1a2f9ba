"""Rendering: the balance overlay's geometry (no OpenGL needed) and a short MP4 written by
``hybrid-recovery play`` in a subprocess with ``MUJOCO_GL=egl`` (skipped, with the reason,
where no OpenGL context can be made)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import mujoco
import numpy as np
import pytest

from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.dynamics.support import signed_distance
from hybrid_recovery.evaluation.play import play
from hybrid_recovery.robot.mjcf import default_qpos
from hybrid_recovery.sim.render import BalanceOverlay, add_overlay, balance_overlay
from hybrid_recovery.sim.scene import build_scene


@pytest.fixture(scope="module")
def standing():
    model, _ = build_scene()
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)  # soles on the ground
    return model, data


def updated_scene(model, data) -> mujoco.MjvScene:
    scene = mujoco.MjvScene(model, maxgeom=1000)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), mujoco.MjvPerturb(),
                           mujoco.MjvCamera(), mujoco.mjtCatBit.mjCAT_ALL, scene)
    return scene


def test_overlay_of_a_still_standing_robot(standing):
    model, data = standing
    overlay = balance_overlay(model, data)
    ref = RobotModel(model).balance_state(data.qpos, data.qvel)
    np.testing.assert_allclose(overlay.com, ref.com, atol=1e-9)
    np.testing.assert_allclose(overlay.capture_point, overlay.com[:2], atol=1e-12)  # ċ = 0
    assert overlay.feet_polygon.shape == (4, 2)  # both soles: one rectangle around them
    assert signed_distance(overlay.capture_point, overlay.feet_polygon) < -0.05
    np.testing.assert_allclose(overlay.support_polygon, overlay.feet_polygon)
    assert not overlay.push_force.any()


def test_overlay_geoms_are_where_the_quantities_are(standing):
    model, data = standing
    overlay = balance_overlay(model, data, push_force=np.array([200.0, 0.0, 0.0]))
    scene = updated_scene(model, data)
    first = scene.ngeom
    added = add_overlay(scene, overlay)
    # CoM sphere + its plumb line, ξ sphere, 4 edges of C_feet (C is the same), push arrow
    assert added == 3 + 4 + 1
    geoms = [scene.geoms[first + k] for k in range(added)]
    np.testing.assert_allclose(geoms[0].pos, overlay.com)
    assert geoms[0].type == mujoco.mjtGeom.mjGEOM_SPHERE
    np.testing.assert_allclose(geoms[2].pos[:2], overlay.capture_point)
    assert 0.0 < geoms[2].pos[2] < 0.05  # on the ground
    edge_mid = [g.pos[:2] for g in geoms[3:7]]
    poly = overlay.feet_polygon
    np.testing.assert_allclose(edge_mid, (poly + np.roll(poly, -1, 0)) / 2, atol=1e-9)
    assert all(g.pos[2] < 0.01 for g in geoms[3:7])
    arrow = geoms[7]
    assert arrow.type == mujoco.mjtGeom.mjGEOM_ARROW
    assert arrow.pos[0] < overlay.push_point[0]  # the arrow starts behind the torso


def test_polygons_of_one_and_two_points_and_a_full_scene(standing):
    model, data = standing
    base = dict(com=np.zeros(3), capture_point=np.zeros(2), push_force=np.zeros(3),
                push_point=np.zeros(3))
    for k, expected in ((0, 3), (1, 4), (2, 4)):
        poly = np.arange(2 * k, dtype=float).reshape(k, 2)
        overlay = BalanceOverlay(feet_polygon=poly, support_polygon=poly, **base)
        assert add_overlay(updated_scene(model, data), overlay) == expected
    full = updated_scene(model, data)
    full.ngeom = full.maxgeom
    overlay = BalanceOverlay(feet_polygon=np.zeros((0, 2)), support_polygon=np.zeros((0, 2)),
                             **base)
    assert add_overlay(full, overlay) == 0


def test_play_validates_its_arguments(tmp_path):
    with pytest.raises(ValueError, match=r"^unknown pose 'lying': choose one of \["):
        play(tmp_path / "x.mp4", pose="lying")
    with pytest.raises(ValueError, match=r"^fps must divide the 50 Hz control rate "
                                         r"\(25 or 50\), got 30$"):
        play(tmp_path / "x.mp4", fps=30)
    with pytest.raises(ValueError, match=r"^seconds must be > 0, got 0.0$"):
        play(tmp_path / "x.mp4", seconds=0.0)


_GL_PROBE = textwrap.dedent("""
    import mujoco
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    mujoco.Renderer(model, 48, 64).close()
""")


def _egl_env() -> dict:
    env = dict(os.environ, MUJOCO_GL="egl")
    env.pop("PYOPENGL_PLATFORM", None)
    return env


def test_play_writes_a_short_mp4(tmp_path):
    probe = subprocess.run([sys.executable, "-c", _GL_PROBE], env=_egl_env(),
                           capture_output=True, text=True, timeout=120)
    if probe.returncode != 0:
        pytest.skip("no OpenGL context for offscreen rendering (MUJOCO_GL=egl): "
                    + (probe.stderr.strip().splitlines() or ["?"])[-1])
    out = tmp_path / "clip.mp4"
    run = subprocess.run(
        [sys.executable, "-m", "hybrid_recovery.cli.main", "play", "--seconds", "0.4",
         "--push", "250", "--push-time", "0.1", "--out", str(out)],
        env=_egl_env(), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "(10 frames at 25 fps)" in run.stdout
    import imageio.v2 as imageio

    with imageio.get_reader(str(out)) as reader:
        assert reader.get_meta_data()["fps"] == 25
        frames = [np.asarray(f) for f in reader]
    assert len(frames) == 10
    assert frames[0].shape == (480, 640, 3)
    assert frames[0].std() > 5  # a picture, not a blank
    assert np.abs(frames[-1].astype(int) - frames[0]).mean() > 0.1  # the robot moved


# --- without OpenGL: the backend choice and the software renderer ---------------------------

def test_backend_choice_before_mujoco_is_imported(monkeypatch):
    from hybrid_recovery.sim import gl_backend as _gl_backend

    monkeypatch.delitem(sys.modules, "mujoco")  # as before the first import
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "PYOPENGL_PLATFORM", "MUJOCO_GL"):
        monkeypatch.setenv(name, "")  # recorded, so that the test leaves them as they were
        monkeypatch.delenv(name)
    for libraries, expected in (({"EGL", "OSMesa"}, "egl"), ({"OSMesa"}, "osmesa"),
                                (set(), "disable")):
        os.environ.pop("MUJOCO_GL", None)
        os.environ.pop("PYOPENGL_PLATFORM", None)
        monkeypatch.setattr(_gl_backend.ctypes.util, "find_library",
                            lambda name, libs=libraries: f"lib{name}.so" if name in libs else None)
        assert _gl_backend.select_gl_backend() == expected
        assert os.environ["MUJOCO_GL"] == expected
    monkeypatch.setenv("MUJOCO_GL", "osmesa")  # the user's choice stands
    assert _gl_backend.select_gl_backend() == "osmesa"
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.setenv("DISPLAY", ":0")  # a display: MuJoCo's default (GLFW) works
    assert _gl_backend.select_gl_backend() == ""
    assert "MUJOCO_GL" not in os.environ


def test_renderer_backend_argument_is_checked():
    from hybrid_recovery.sim.render import BalanceRenderer

    with pytest.raises(ValueError, match=r"^backend must be one of \['auto', 'opengl', "
                                         r"'software'\], got 'vulkan'$"):
        BalanceRenderer(backend="vulkan")


def _foreground(frame: np.ndarray) -> np.ndarray:
    """Pixels that differ from the background colour of the top-left corner."""
    return np.abs(frame.astype(int) - frame[2, 2].astype(int)).sum(-1) > 40


def test_software_frame_puts_the_robot_where_opengl_does(standing):
    """The software renderer projects with MuJoCo's own camera: the robot's silhouette
    (the pixels above the horizon, where only the robot and the overlay are) overlaps
    the OpenGL frame's."""
    from hybrid_recovery.sim.gl_backend import gl_context_works
    from hybrid_recovery.sim.render import BalanceRenderer

    if not gl_context_works():
        pytest.skip("no OpenGL context to compare with")
    model, data = standing
    overlay = balance_overlay(model, data, push_force=np.array([200.0, 0.0, 0.0]))
    frames = {}
    for backend in ("opengl", "software"):
        renderer = BalanceRenderer(backend=backend, elevation=5.0)  # look up: sky behind
        frames[backend] = renderer.frame(data.qpos, overlay, 0.04)
        renderer.close()
    assert frames["software"].shape == frames["opengl"].shape == (480, 640, 3)
    sky = slice(0, 200)  # above the horizon in both frames at this elevation
    gl, sw = (_foreground(frames[b])[sky] for b in ("opengl", "software"))
    assert gl.sum() > 2000 and sw.sum() > 2000
    assert (gl & sw).sum() / (gl | sw).sum() > 0.7


def test_demo_video_without_opengl(tmp_path, monkeypatch, capsys):
    """With the context probe failing, the demo's video path draws in software and writes
    an MP4 of 6 s at 25 fps of a robot that moves."""
    import imageio.v2 as imageio

    import hybrid_recovery.sim.render as render
    from hybrid_recovery.demo.comparison import _video

    monkeypatch.setattr(render, "gl_context_works", lambda: False)
    _video("zero", tmp_path)
    printed = capsys.readouterr().out
    assert f"video: {tmp_path / 'demo.mp4'} (renderer: software (matplotlib))" in printed
    with imageio.get_reader(str(tmp_path / "demo.mp4")) as reader:
        frames = [np.asarray(f) for f in reader]
    assert len(frames) == 150
    assert frames[0].shape == (480, 640, 3)
    assert frames[0].std() > 5  # a picture, not a blank
    assert np.abs(frames[-1].astype(int) - frames[0]).mean() > 0.1  # the robot moved


def test_play_with_opengl_disabled_draws_in_software_and_prints_no_gl_errors(tmp_path):
    out = tmp_path / "clip.mp4"
    env = dict(os.environ, MUJOCO_GL="disable")
    env.pop("PYOPENGL_PLATFORM", None)
    run = subprocess.run(
        [sys.executable, "-m", "hybrid_recovery.cli.main", "play", "--seconds", "0.4",
         "--out", str(out)], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "(10 frames at 25 fps)\nrenderer: software (matplotlib)\n" in run.stdout
    assert "GLFW" not in run.stderr and "OpenGL" not in run.stderr
    import imageio.v2 as imageio

    with imageio.get_reader(str(out)) as reader:
        assert len([f for f in reader]) == 10


def test_software_renderer_projects_a_sphere_where_a_pinhole_camera_sees_it():
    """No OpenGL needed: a red sphere drawn by the software renderer lands where an
    independent pinhole projection of MuJoCo's free camera (look-at, distance, azimuth,
    elevation, vertical field of view) puts it, with the radius that projection gives."""
    from hybrid_recovery.sim.software_renderer import SoftwareRenderer

    center, radius = np.array([0.3, -0.2, 0.6]), 0.08
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><worldbody><geom type="sphere" size="{radius}" '
        f'pos="{center[0]} {center[1]} {center[2]}" rgba="1 0 0 1"/></worldbody></mujoco>')
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    height, width = 240, 320
    renderer = SoftwareRenderer(model, height, width)
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:], camera.distance = [0.0, 0.0, 0.5], 2.5
    camera.azimuth, camera.elevation = 120.0, -20.0
    renderer.update_scene(data, camera)
    frame = renderer.render().astype(int)
    renderer.close()

    az, el = np.radians(camera.azimuth), np.radians(camera.elevation)
    forward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    position = np.array(camera.lookat) - camera.distance * forward
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = center - position
    z = d @ forward
    focal = 0.5 * height / np.tan(np.radians(model.vis.global_.fovy) / 2)
    expected = np.array([0.5 * width + focal * (d @ right) / z,
                         0.5 * height - focal * (d @ up) / z])

    red = (frame[..., 0] > 150) & (frame[..., 1] < 80) & (frame[..., 2] < 80)
    rows, cols = np.nonzero(red)
    np.testing.assert_allclose([cols.mean(), rows.mean()], expected, atol=1.5)
    assert np.sqrt(red.sum() / np.pi) == pytest.approx(focal * radius / z, rel=0.1)
