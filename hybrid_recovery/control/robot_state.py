"""One control tick's view of the robot: dynamics, centroidal terms, feet and contacts.

:class:`StateReader` copies the measured ``qpos``/``qvel`` of a simulation (or of a
noisy measurement of it) into a private ``MjData`` and evaluates there what the
whole-body QP needs, all in MuJoCo's qvel coordinates (free joint: world linear,
body angular velocity):

* M (nv, nv) with the rotor armature, and the bias h = C q̇ + g (nv,) from MuJoCo;
* the centroidal momentum matrix A (6, nv) and drift Ȧ q̇ (6,) of the dynamics layer's
  Pinocchio model (``RobotModel.model``, same conventions as
  :meth:`hybrid_recovery.dynamics.RobotModel.centroidal_momentum_matrix`), here on a
  single-state path (≈ 25 µs instead of ≈ 0.5 ms for the batched API);
* sole-centre poses, 6-D Jacobians and J̇ q̇, and the sole-corner Jacobians;
* sole contact forces and non-foot contacts, read from the simulation's contacts
  (the robot's foot force sensors).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from hybrid_recovery.dynamics import GRAVITY, RobotModel
from hybrid_recovery.robot import constants

SIDES: tuple[str, str] = ("left", "right")
CORNERS: tuple[str, ...] = ("fl", "fr", "rl", "rr")


@dataclass
class FootState:
    """A sole (site ``<side>_foot``), world frame.

    Attributes:
        position: Sole centre p, shape (3,) [m].
        rotation: Sole orientation R, shape (3, 3).
        velocity: Spatial velocity [ω; v] (world axes, at the sole centre), shape (6,).
        jacobian: J with [ω; v] = J q̇, shape (6, nv).
        bias_acc: J̇ q̇, shape (6,).
        corners: Corner positions, shape (4, 3) [m], order fl, fr, rl, rr.
        corner_jacobians: Translational Jacobians of the corners, shape (4, 3, nv).
        cop_corners: Corners of the CoP region the ankle torques can hold under the full
            body weight (the sole clipped to |x| ≤ τ_pitch/(m g), |y| ≤ τ_roll/(m g)
            about the ankle), shape (4, 3) [m].
        normal_force: Sum of contact normal forces on the foot [N].
    """

    position: np.ndarray
    rotation: np.ndarray
    velocity: np.ndarray
    jacobian: np.ndarray
    bias_acc: np.ndarray
    corners: np.ndarray
    corner_jacobians: np.ndarray
    cop_corners: np.ndarray
    normal_force: float


@dataclass
class RobotState:
    """Everything one QP tick needs, MuJoCo coordinates, world axes.

    Attributes:
        qpos: shape (nq,). qvel: shape (nv,).
        mass_matrix: M, shape (nv, nv) [kg, kg·m, kg·m²].
        bias: h = C q̇ + g, shape (nv,) [N, N·m].
        cmm: A with [p_l; L] = A q̇, shape (6, nv).
        cmm_drift: Ȧ q̇, shape (6,) [N, N·m].
        com: c, shape (3,) [m]. com_vel: ċ, shape (3,) [m/s].
        angular_momentum: L about the CoM, shape (3,) [kg·m²/s].
        pelvis_rotation: R, shape (3, 3). pelvis_angvel: ω (world), shape (3,) [rad/s].
        pelvis_jacobian: J_ω with ω = J_ω q̇, shape (3, nv).
        pelvis_bias_acc: J̇_ω q̇, shape (3,) [rad/s²].
        feet: Left and right :class:`FootState`.
        non_foot_contact: Any robot geom other than the soles' bodies touches the floor.
        mass: m [kg].
    """

    qpos: np.ndarray
    qvel: np.ndarray
    mass_matrix: np.ndarray
    bias: np.ndarray
    cmm: np.ndarray
    cmm_drift: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    angular_momentum: np.ndarray
    pelvis_rotation: np.ndarray
    pelvis_angvel: np.ndarray
    pelvis_jacobian: np.ndarray
    pelvis_bias_acc: np.ndarray
    feet: tuple[FootState, FootState]
    non_foot_contact: bool
    mass: float


class StateReader:
    """Evaluates :class:`RobotState` from a model's ``qpos``/``qvel`` and contacts.

    Args:
        model: The torque-controlled model the controller runs on (see
            :func:`hybrid_recovery.control.torque_model.load_torque_model`); it needs the
            sole-centre and sole-corner sites ``<side>_foot[_{fl,fr,rl,rr}]``.
        ankle_torque: Ankle pitch and roll torque limits (τ_pitch, τ_roll) [N·m] that
            bound the CoP region ``FootState.cop_corners``.

    Raises:
        ValueError: A site is missing (e.g. the manufacturer's model has no sole sites).
    """

    def __init__(self, model: mujoco.MjModel, ankle_torque: tuple[float, float] = (
            float(constants.EFFORT_LIMITS[4]), float(constants.EFFORT_LIMITS[5]))) -> None:
        names = [f"{s}_foot" for s in SIDES] + [f"{s}_foot_{c}" for s in SIDES for c in CORNERS]
        for name in [*names, "imu"]:
            if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name) < 0:
                raise ValueError(f"model has no site '{name}': the QP controller needs the sole "
                                 "and IMU sites of models/h1_2/h1_2.xml")
        self.model = model
        self.data = mujoco.MjData(model)
        self.robot = RobotModel(model)
        self.mass = self.robot.mass
        nv = model.nv
        self._q_index = np.r_[0:3, 4:7, 3, 7 : model.nq]
        self._pelvis = model.body(constants.PELVIS_BODY).id
        self._foot_sites = [model.site(f"{s}_foot").id for s in SIDES]
        self._foot_bodies = [model.body(b).id for b in constants.FOOT_BODIES]
        self._corner_sites = [[model.site(f"{s}_foot_{c}").id for c in CORNERS] for s in SIDES]
        self._floor_bodies = {0}
        weight = self.mass * GRAVITY
        reach = np.array([ankle_torque[0], ankle_torque[1]]) / weight
        local = np.array([[model.site_pos[c] for c in sites] for sites in self._corner_sites])
        local[..., :2] = np.clip(local[..., :2], -reach, reach)
        self._cop_local = local  # (2, 4, 3) in the foot body frame
        self._mass = np.zeros((nv, nv))
        self._bias = np.zeros(nv)

    def read(self, data: mujoco.MjData) -> RobotState:
        """The state of ``data`` (its qpos, qvel and contact list).

        Args:
            data: Simulation data; only ``qpos``, ``qvel`` and ``contact`` are read.

        Returns:
            A fresh :class:`RobotState`.
        """
        m, d = self.model, self.data
        d.qpos[:] = data.qpos
        d.qvel[:] = data.qvel
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_fullM(m, d, self._mass)
        mujoco.mj_rne(m, d, 0, self._bias)
        rot = d.xmat[self._pelvis].reshape(3, 3).copy()
        cmm, drift, com, momentum = self._centroidal(rot, d.qpos, d.qvel)
        jac_pelvis = np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, None, jac_pelvis, self._pelvis)
        jdot_pelvis = np.zeros((3, m.nv))
        mujoco.mj_jacDot(m, d, None, jdot_pelvis, d.xpos[self._pelvis], self._pelvis)
        forces, non_foot = self._contacts(data)
        feet = (self._foot(0, forces[0]), self._foot(1, forces[1]))
        return RobotState(
            qpos=d.qpos.copy(), qvel=d.qvel.copy(), mass_matrix=self._mass.copy(),
            bias=self._bias.copy(), cmm=cmm, cmm_drift=drift, com=com,
            com_vel=momentum[:3] / self.mass, angular_momentum=momentum[3:],
            pelvis_rotation=rot, pelvis_angvel=jac_pelvis @ d.qvel,
            pelvis_jacobian=jac_pelvis, pelvis_bias_acc=jdot_pelvis @ d.qvel, feet=feet,
            non_foot_contact=non_foot, mass=self.mass,
        )

    def _centroidal(self, rot: np.ndarray, qpos: np.ndarray, qvel: np.ndarray):
        """A, Ȧ q̇, c and [p_l; L] from Pinocchio (MuJoCo → Pinocchio: q, v, a at q̈ = 0)."""
        model, data = self.robot.model, self.robot.data
        q = qpos[self._q_index]
        v = qvel.copy()
        v[0:3] = rot.T @ qvel[0:3]
        a = np.zeros_like(v)
        a[0:3] = -np.cross(qvel[3:6], v[0:3])
        cmm = pin.ccrba(model, data, q, v).copy()
        cmm[:, 0:3] = cmm[:, 0:3] @ rot.T
        momentum = data.hg.vector.copy()
        drift = pin.computeCentroidalMomentumTimeVariation(model, data, q, v, a).vector.copy()
        return cmm, drift, data.com[0].copy(), momentum

    def _foot(self, side: int, normal_force: float) -> FootState:
        m, d = self.model, self.data
        site = self._foot_sites[side]
        jac = np.zeros((6, m.nv))
        mujoco.mj_jacSite(m, d, jac[3:], jac[:3], site)
        jdot = np.zeros((6, m.nv))
        pos = d.site_xpos[site].copy()
        mujoco.mj_jacDot(m, d, jdot[3:], jdot[:3], pos, self._foot_bodies[side])
        corners = np.empty((4, 3))
        corner_jac = np.empty((4, 3, m.nv))
        for k, cid in enumerate(self._corner_sites[side]):
            corners[k] = d.site_xpos[cid]
            mujoco.mj_jacSite(m, d, corner_jac[k], None, cid)
        body = self._foot_bodies[side]
        cop_corners = d.xpos[body] + self._cop_local[side] @ d.xmat[body].reshape(3, 3).T
        return FootState(
            position=pos, rotation=d.site_xmat[site].reshape(3, 3).copy(),
            velocity=jac @ d.qvel, jacobian=jac, bias_acc=jdot @ d.qvel, corners=corners,
            corner_jacobians=corner_jac, cop_corners=cop_corners, normal_force=normal_force,
        )

    def _contacts(self, data: mujoco.MjData) -> tuple[list[float], bool]:
        """Normal force on each sole [N] and whether any other robot geom touches."""
        m = self.model
        forces = [0.0, 0.0]
        non_foot = False
        wrench = np.zeros(6)
        for i in range(data.ncon):
            contact = data.contact[i]
            bodies = (m.geom_bodyid[contact.geom[0]], m.geom_bodyid[contact.geom[1]])
            robot_body = bodies[1] if bodies[0] in self._floor_bodies else bodies[0]
            if robot_body in self._foot_bodies:
                mujoco.mj_contactForce(m, data, i, wrench)
                forces[self._foot_bodies.index(robot_body)] += wrench[0]
            elif contact.dist < 0.0:
                non_foot = True
        return forces, non_foot
