"""The robot's MuJoCo state from one ``LowState_``, for controllers that read a full state.

The joints are measured. The pelvis orientation R_b = R_imu R_s⁻¹ comes from the torso IMU
through the waist (R_s: the IMU site's orientation in the pelvis frame at the measured
joints), its angular velocity ω_b = R_imu ω_gyro − R_b J_ω,s q̇ likewise. Position and
linear velocity come from leg odometry: the robot's lowest collision point is on the
ground (z = 0), the lower sole does not slide (v_b = −J_p,foot q̇ at zero base velocity)
and keeps its x–y until the other sole becomes the lower one. Contact forces are those of
:func:`mujoco.mj_forward` on that state (no foot force sensors are read).
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.deploy.robot_io import LowStateReading
from hybrid_recovery.robot.mjcf import joint_addresses

FOOT_SITES: tuple[str, str] = ("left_foot", "right_foot")
"""The sole-centre sites the odometry anchors on."""

_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


class StateEstimate:
    """Fills an ``MjData`` of ``model`` from each :class:`LowStateReading`.

    Args:
        model: The controller's model (with the ``imu`` site and the two sole sites).
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model, self.data = model, mujoco.MjData(model)
        self.qadr, self.dadr = joint_addresses(model)
        self.imu = model.site("imu").id
        self.feet = [model.site(name).id for name in FOOT_SITES]
        floor = {g for g in range(model.ngeom) if model.geom_bodyid[g] == 0}
        self.geoms = np.array([g for g in range(model.ngeom) if g not in floor
                               and (model.geom_contype[g] or model.geom_conaffinity[g])])
        self.stance: int | None = None
        """The sole the odometry anchors on (0 left, 1 right; None before a reading)."""
        self._anchor = np.zeros(2)
        self._t0: float | None = None

    def reset(self) -> None:
        """Forget the odometry's anchor and the time origin."""
        self.stance, self._t0 = None, None

    def update(self, state: LowStateReading) -> mujoco.MjData:
        """The estimated state, forward dynamics done (sensors, contacts); ``data.time``
        counts from the first reading [s]. ``actuator_force`` is NaN: the motors' torque
        estimate lags the commands by the link's latency, so the hybrid's torque check
        (:mod:`hybrid_recovery.control.model_validity`) does not run on the robot."""
        m, d = self.model, self.data
        if self._t0 is None:
            self._t0 = state.t_receive
        d.time = state.t_receive - self._t0
        d.qpos[:7] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]
        d.qvel[:6] = 0.0
        d.qpos[self.qadr], d.qvel[self.dadr] = state.q, state.dq
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        jacr = np.zeros((3, m.nv))
        mujoco.mj_jacSite(m, d, None, jacr, self.imu)
        r_imu = np.zeros(9)
        mujoco.mju_quat2Mat(r_imu, state.quat / np.linalg.norm(state.quat))
        r_base = r_imu.reshape(3, 3) @ d.site_xmat[self.imu].reshape(3, 3).T
        omega = r_imu.reshape(3, 3) @ state.gyro - r_base @ (jacr @ d.qvel)
        mujoco.mju_mat2Quat(d.qpos[3:7], r_base.ravel())
        d.qvel[3:6] = r_base.T @ omega  # the free joint's angular velocity: base axes
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        feet = d.site_xpos[self.feet]
        stance = int(np.argmin(feet[:, 2]))
        if stance != self.stance:
            self.stance = stance
            self._anchor = feet[stance, :2] + d.qpos[:2]
        d.qpos[:2] = self._anchor - feet[stance, :2]
        d.qpos[2] = -self._lowest_point()  # computed with the pelvis at z = 0
        jacp = np.zeros((3, m.nv))
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_jacSite(m, d, jacp, None, self.feet[stance])
        d.qvel[:3] = -(jacp @ d.qvel)  # the free joint's linear velocity: world axes
        mujoco.mj_forward(m, d)
        d.actuator_force[:] = np.nan  # no torque reading aligned with the loop's commands
        return d

    def _lowest_point(self) -> float:
        """The height of the lowest corner of the robot's collision geoms' boxes [m] (at
        the kinematics last computed)."""
        m, d, g = self.model, self.data, self.geoms
        local = m.geom_aabb[g, None, :3] + _CORNERS[None] * m.geom_aabb[g, None, 3:]
        world_z = d.geom_xpos[g, None, 2] + np.einsum("gj,gcj->gc",
                                                      d.geom_xmat[g, 6:9], local)
        return float(world_z.min())
