"""Actor observation o_t (paper §III-C): proprioception measurable on the robot.

The terms, in order, with their widths (87 in all); angular velocity and gravity are
those of the torso IMU, in the torso frame:

=====================  ====  ==========================================
base_ang_vel              3  ω_IMU [rad/s]
projected_gravity         3  R_IMUᵀ (0, 0, −1)
joint_pos                27  q − q* [rad], motor order
joint_vel                27  q̇ [rad/s]
last_action              27  a_{t−1} (unscaled policy output)
=====================  ====  ==========================================
"""

from __future__ import annotations

import numpy as np
from array_api_compat import array_namespace, device

from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS, NUM_JOINTS

ACTOR_TERMS: tuple[tuple[str, int], ...] = (
    ("base_ang_vel", 3),
    ("projected_gravity", 3),
    ("joint_pos", NUM_JOINTS),
    ("joint_vel", NUM_JOINTS),
    ("last_action", NUM_JOINTS),
)
"""Ordered (name, width) of the actor observation."""

ACTOR_OBS_DIM = sum(width for _, width in ACTOR_TERMS)


def projected_gravity(quat_wxyz: Array) -> Array:
    """Gravity direction in the body frame, g_b = Rᵀ (0, 0, −1).

    Args:
        quat_wxyz: Body orientation (w, x, y, z), shape (..., 4).

    Returns:
        g_b, shape (..., 3); (0, 0, −1) when upright.
    """
    xp = array_namespace(quat_wxyz)
    w, x, y, z = (quat_wxyz[..., i] for i in range(4))
    norm2 = w * w + x * x + y * y + z * z
    # third row of R (world z-axis in the body frame), negated
    gx = 2 * (x * z - w * y)
    gy = 2 * (y * z + w * x)
    gz = 1 - 2 * (x * x + y * y)
    return -xp.stack([gx, gy, gz], axis=-1) / norm2[..., None]


def actor_observation(
    ang_vel: Array,
    quat_wxyz: Array,
    joint_pos: Array,
    joint_vel: Array,
    last_action: Array,
    default_joint_pos: np.ndarray = DEFAULT_JOINT_POS,
) -> Array:
    """Builds o_t from raw proprioception (no noise); numpy arrays or torch tensors.

    Args:
        ang_vel: IMU angular velocity, shape (N, 3) [rad/s].
        quat_wxyz: IMU orientation, shape (N, 4).
        joint_pos: q in motor order, shape (N, 27) [rad].
        joint_vel: q̇, shape (N, 27) [rad/s].
        last_action: a_{t−1}, shape (N, 27).
        default_joint_pos: q*, shape (27,) [rad].

    Returns:
        o_t, shape (N, 87), float32.
    """
    xp = array_namespace(ang_vel, quat_wxyz, joint_pos, joint_vel, last_action)
    q_star = xp.asarray(default_joint_pos, copy=True, device=device(joint_pos))  # float64
    parts = [ang_vel, projected_gravity(quat_wxyz), joint_pos - q_star, joint_vel, last_action]
    return xp.astype(xp.concat(parts, axis=-1), xp.float32)


def noise_halfwidths(ang_vel: float, gravity: float, joint_pos: float,
                     joint_vel: float) -> np.ndarray:
    """Per-entry half-widths of the additive uniform noise on o_t, shape (87,)."""
    widths = {"base_ang_vel": ang_vel, "projected_gravity": gravity, "joint_pos": joint_pos,
              "joint_vel": joint_vel, "last_action": 0.0}
    return np.concatenate([np.full(w, widths[name]) for name, w in ACTOR_TERMS]).astype(np.float32)
