"""Proprioception read from a single MuJoCo ``MjData``, as the robot's sensors give it.

Works on any H1-2 model (ours or the reference mesh model): the IMU is the torso link's
``imu`` site when present, else the torso body frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.robot import constants


@dataclass(frozen=True)
class ProprioceptionMap:
    """Addresses of the robot's joints and IMU frame in one model."""

    qadr: np.ndarray
    dadr: np.ndarray
    imu_type: int
    imu_id: int

    @classmethod
    def of(cls, model: mujoco.MjModel) -> ProprioceptionMap:
        joint = mujoco.mjtObj.mjOBJ_JOINT
        ids = [mujoco.mj_name2id(model, joint, n) for n in constants.JOINT_NAMES]
        if min(ids) < 0:
            missing = [n for n, i in zip(constants.JOINT_NAMES, ids, strict=True) if i < 0]
            raise ValueError(f"model lacks joints {missing}")
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "imu")
        if site >= 0:
            imu_type, imu_id = int(mujoco.mjtObj.mjOBJ_SITE), site
        else:
            imu_type = int(mujoco.mjtObj.mjOBJ_BODY)
            imu_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, constants.IMU_BODY)
        return cls(model.jnt_qposadr[ids], model.jnt_dofadr[ids], imu_type, imu_id)


def read_proprioception(model: mujoco.MjModel, data: mujoco.MjData, where: ProprioceptionMap
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(ω_IMU (3,) [rad/s] in the IMU frame, IMU quaternion (4,) w,x,y,z, q (27,), q̇ (27,)).

    Needs the position and velocity stages of ``data`` to be current (after mj_forward or
    mj_step1).
    """
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, where.imu_type, where.imu_id, vel, 1)
    xmat = (data.site_xmat if where.imu_type == mujoco.mjtObj.mjOBJ_SITE else data.xmat)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, xmat[where.imu_id])
    return vel[:3].copy(), quat, data.qpos[where.qadr].copy(), data.qvel[where.dadr].copy()
