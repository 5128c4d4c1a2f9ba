"""The OpenGL backend for offscreen video, chosen before MuJoCo is imported.

MuJoCo reads ``MUJOCO_GL`` once, when Python first imports it, so the package imports this
module before anything else. Where the user has not set ``MUJOCO_GL`` and no display is
attached, :func:`select_gl_backend` picks the first backend whose library is installed:
EGL, then OSMesa, else ``disable`` (MuJoCo then never tries GLFW, which prints errors on a
machine without a display). Whether a context can really be made is asked of a child
process (:func:`gl_context_works`), so that a crashing driver cannot take the caller down
and its messages do not reach the caller's terminal; where none can, the renderers draw
in software (``hybrid_recovery.sim.software_renderer``).
"""

from __future__ import annotations

import ctypes.util
import functools
import os
import subprocess
import sys

BACKENDS = (("egl", "EGL"), ("osmesa", "OSMesa"))
"""(MUJOCO_GL value, shared library name) in the order they are tried."""
DISABLED = "disable"
"""The MUJOCO_GL value that makes MuJoCo load no OpenGL backend."""
PROBE_TIMEOUT = 60.0
"""Longest wait for the child process that makes a test context [s]."""

_PROBE = (
    "import mujoco\n"
    "model = mujoco.MjModel.from_xml_string('<mujoco><worldbody/></mujoco>')\n"
    "renderer = mujoco.Renderer(model, 16, 16)\n"
    "renderer.render()\n"
    "renderer.close()\n"
)


def select_gl_backend() -> str:
    """Sets ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM``) for a machine without a display.

    Leaves the environment alone where ``MUJOCO_GL`` is already set (not empty), where MuJoCo is
    already imported (too late to choose) or where a display is attached (MuJoCo's own
    default, GLFW, works there).

    Returns:
        The backend now in effect: ``"egl"``, ``"osmesa"``, ``"disable"``, the user's
        value, or ``""`` for MuJoCo's default.
    """
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    if "mujoco" in sys.modules or not sys.platform.startswith("linux"):
        return ""
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return ""
    for backend, library in BACKENDS:
        if ctypes.util.find_library(library):
            os.environ["MUJOCO_GL"] = backend
            os.environ.setdefault("PYOPENGL_PLATFORM", backend)
            return backend
    os.environ["MUJOCO_GL"] = DISABLED
    return DISABLED


def loaded_backend() -> str:
    """The ``MUJOCO_GL`` value MuJoCo was imported with (the environment's where it is not
    yet imported)."""
    module = sys.modules.get("mujoco.rendering.classic.gl_context")
    value = getattr(module, "_MUJOCO_GL", None)
    return value if isinstance(value, str) else os.environ.get("MUJOCO_GL", "")


@functools.cache
def gl_context_works() -> bool:
    """Whether a child process with the backend of this process's MuJoCo can render one
    frame.

    Cached for the process: the backend cannot change once MuJoCo is imported.
    """
    backend = loaded_backend()
    if backend.lower() in (DISABLED, "disabled", "off", "false", "0"):
        return False
    env = dict(os.environ, MUJOCO_GL=backend)
    if backend.lower() in ("egl", "osmesa"):
        env["PYOPENGL_PLATFORM"] = backend.lower()
    try:
        probe = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True,
                               timeout=PROBE_TIMEOUT, env=env)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return probe.returncode == 0


select_gl_backend()
