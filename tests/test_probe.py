"""The probes' headings, against MuJoCo's rotation matrices of known attitudes."""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.sim.initial_states import quat_from_euler
from hybrid_recovery.training.probe import heading_xy


def _xmat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    quat = quat_from_euler(np.array(roll), np.array(pitch), np.array(yaw))
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, quat)
    return mat


def test_the_heading_is_the_yaw_whatever_the_roll_and_a_moderate_pitch():
    rng = np.random.default_rng(0)
    yaw = rng.uniform(-np.pi, np.pi, 20)
    roll, pitch = rng.uniform(-1.0, 1.0, 20), rng.uniform(-1.2, 1.2, 20)
    xmat = np.stack([_xmat(r, p, y) for r, p, y in zip(roll, pitch, yaw, strict=True)])
    heading = heading_xy(xmat)
    np.testing.assert_allclose(heading, np.stack([np.cos(yaw), np.sin(yaw)], 1), atol=1e-12)


def test_an_x_axis_straight_up_has_a_defined_heading():
    heading = heading_xy(_xmat(0.0, -np.pi / 2, 0.3)[None])
    np.testing.assert_allclose(heading, [[1.0, 0.0]])
    assert np.isfinite(heading).all()
