"""MuJoCo ↔ Pinocchio state conventions for a free-floating robot.

MuJoCo: ``qpos = [p (3), quat w,x,y,z (4), joints]``, ``qvel = [v_world (3), ω_body (3),
joints]``, ``qacc`` its time derivative. Pinocchio: ``q = [p, quat x,y,z,w, joints]``,
``v = [Rᵀ v_world, ω_body, joints]`` (the base's spatial velocity in the base frame).
"""

from __future__ import annotations

import numpy as np


def quat_wxyz_to_matrix(quat: np.ndarray) -> np.ndarray:
    """Rotation matrices from unit quaternions (w, x, y, z).

    Args:
        quat: Quaternions, shape (..., 4).

    Returns:
        Rotation matrices R (body → world), shape (..., 3, 3).
    """
    q = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def qpos_to_pin(qpos: np.ndarray) -> np.ndarray:
    """Pinocchio configuration q from MuJoCo qpos, shape (..., nq)."""
    return np.concatenate([qpos[..., 0:3], qpos[..., 4:7], qpos[..., 3:4], qpos[..., 7:]], -1)


def qvel_to_pin(qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
    """Pinocchio velocity v = [Rᵀ v_world, ω_body, q̇_joints] from MuJoCo qvel, shape (..., nv)."""
    rot = quat_wxyz_to_matrix(qpos[..., 3:7])
    lin = np.einsum("...ji,...j->...i", rot, qvel[..., 0:3])
    return np.concatenate([lin, qvel[..., 3:]], -1)


def qacc_to_pin(qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray) -> np.ndarray:
    """Pinocchio acceleration a = dv/dt from MuJoCo qacc, shape (..., nv).

    d/dt (Rᵀ v_world) = Rᵀ a_world − ω × (Rᵀ v_world) since Ṙ = R [ω]×.
    """
    rot = quat_wxyz_to_matrix(qpos[..., 3:7])
    lin_vel = np.einsum("...ji,...j->...i", rot, qvel[..., 0:3])
    lin = np.einsum("...ji,...j->...i", rot, qacc[..., 0:3]) - np.cross(qvel[..., 3:6], lin_vel)
    return np.concatenate([lin, qacc[..., 3:]], -1)


def velocity_map(qpos: np.ndarray, nv: int) -> np.ndarray:
    """Matrix T with v = T qvel: block-diag(Rᵀ, I₃, I), shape (nv, nv) for a single qpos."""
    t = np.eye(nv)
    t[0:3, 0:3] = quat_wxyz_to_matrix(qpos[3:7]).T
    return t
