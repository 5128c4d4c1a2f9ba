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
        # index arrays (a list index is converted on every use): both soles, then the corners
        self._site_index = np.array([*self._foot_sites, *np.ravel(self._corner_sites)])
        self._foot_body_index = np.array(self._foot_bodies)
        self._corner_jobs = [(side, k, site) for side in (0, 1)
                             for k, site in enumerate(self._corner_sites[side])]
        self._geom_body = model.geom_bodyid.tolist()
        self._nv = nv
        self._wrench = np.zeros(6)  # mj_contactForce's output
        d = self.data  # views of its arrays, kept (each attribute access makes a new one)
        self._qpos, self._qvel, self._xpos, self._xmat = d.qpos, d.qvel, d.xpos, d.xmat
        self._site_xpos, self._site_xmat = d.site_xpos, d.site_xmat

    def read(self, data: mujoco.MjData) -> RobotState:
        """The state of ``data`` (its qpos, qvel and contact list).

        Args:
            data: Simulation data; only ``qpos``, ``qvel`` and ``contact`` are read.

        Returns:
            A fresh :class:`RobotState` (no array is shared with an earlier one).
        """
        m, d, nv = self.model, self.data, self._nv
        self._qpos[:] = data.qpos
        self._qvel[:] = data.qvel
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_comVel(m, d)
        mass_matrix, bias = np.empty((nv, nv)), np.empty(nv)
        mujoco.mj_fullM(m, d, mass_matrix)  # writes every entry
        mujoco.mj_rne(m, d, 0, bias)
        qpos, qvel = self._qpos.copy(), self._qvel.copy()
        rot = self._xmat[self._pelvis].reshape(3, 3).copy()
        cmm, drift, com, momentum = self._centroidal(rot, qpos, qvel)
        # J_ω, J̇_ω of the pelvis (rows 0:6), then J, J̇ of each sole (6:18, 18:30): all their
        # products with q̇ in one call, six rows at a time
        rates = np.empty((30, nv))
        mujoco.mj_jacBody(m, d, None, rates[0:3], self._pelvis)
        mujoco.mj_jacDot(m, d, None, rates[3:6], self._xpos[self._pelvis], self._pelvis)
        self._sole_jacobians(rates[6:30])
        products = (rates.reshape(5, 6, nv) @ qvel).reshape(30)
        forces, non_foot = self._contacts(data)
        return RobotState(
            qpos=qpos, qvel=qvel, mass_matrix=mass_matrix, bias=bias, cmm=cmm,
            cmm_drift=drift, com=com, com_vel=momentum[:3] / self.mass,
            angular_momentum=momentum[3:], pelvis_rotation=rot, pelvis_angvel=products[0:3],
            pelvis_jacobian=rates[0:3], pelvis_bias_acc=products[3:6],
            feet=self._feet(forces, rates[6:30], products[6:30]), non_foot_contact=non_foot,
            mass=self.mass,
        )

    def _centroidal(self, rot: np.ndarray, qpos: np.ndarray, qvel: np.ndarray):
        """A, Ȧ q̇, c and [p_l; L] from Pinocchio (MuJoCo → Pinocchio: q, v, a at q̈ = 0)."""
        model, data = self.robot.model, self.robot.data
        q = qpos[self._q_index]
        v = qvel.copy()
        v[0:3] = rot.T @ qvel[0:3]
        # a_lin = −ω × v_lin (the free flyer's frame turns), in floats (np.cross is slow)
        (w0, w1, w2), (v0, v1, v2) = qvel[3:6].tolist(), v[0:3].tolist()
        a = np.zeros(len(v))
        a[0:3] = (-(w1 * v2 - w2 * v1), -(w2 * v0 - w0 * v2), -(w0 * v1 - w1 * v0))
        cmm = pin.ccrba(model, data, q, v).copy()
        cmm[:, 0:3] = cmm[:, 0:3] @ rot.T
        momentum = data.hg.vector.copy()
        drift = pin.computeCentroidalMomentumTimeVariation(model, data, q, v, a).vector.copy()
        return cmm, drift, data.com[0].copy(), momentum

    def _sole_jacobians(self, rates: np.ndarray) -> None:
        """J (rows 0:6) and J̇ (rows 6:12) of the left sole, then of the right, into
        ``rates`` (24, nv)."""
        m, d = self.model, self.data
        for side in (0, 1):
            jac, jdot = rates[12 * side : 12 * side + 6], rates[12 * side + 6 : 12 * side + 12]
            site = self._foot_sites[side]
            mujoco.mj_jacSite(m, d, jac[3:], jac[:3], site)
            mujoco.mj_jacDot(m, d, jdot[3:], jdot[:3], self._site_xpos[site],
                             self._foot_bodies[side])

    def _feet(self, forces: list[float], rates: np.ndarray, products: np.ndarray
              ) -> tuple[FootState, FootState]:
        """Both soles' states from their J, J̇ (``rates`` (24, nv), see
        :meth:`_sole_jacobians`) and those times q̇ (``products`` (24,))."""
        m, d = self.model, self.data
        sites = self._site_xpos[self._site_index]  # (10, 3): both soles, then the corners
        rotation = self._site_xmat[self._site_index[:2]].reshape(2, 3, 3)
        corners = sites[2:].reshape(2, 4, 3)
        corner_jac = np.empty((2, 4, 3, self._nv))
        for side, k, site in self._corner_jobs:
            mujoco.mj_jacSite(m, d, corner_jac[side, k], None, site)
        bodies = self._foot_body_index
        body_rot = self._xmat[bodies].reshape(2, 3, 3)
        cop_corners = (self._xpos[bodies][:, None]
                       + self._cop_local @ body_rot.transpose(0, 2, 1))
        return (
            FootState(sites[0], rotation[0], products[0:6], rates[0:6], products[6:12],
                      corners[0], corner_jac[0], cop_corners[0], forces[0]),
            FootState(sites[1], rotation[1], products[12:18], rates[12:18], products[18:24],
                      corners[1], corner_jac[1], cop_corners[1], forces[1]),
        )

    def _contacts(self, data: mujoco.MjData) -> tuple[list[float], bool]:
        """Normal force on each sole [N] and whether any other robot geom touches."""
        forces = [0.0, 0.0]
        non_foot = False
        if data.ncon == 0:
            return forces, non_foot
        contact = data.contact
        geom_body, feet, floor = self._geom_body, self._foot_bodies, self._floor_bodies
        wrench = self._wrench
        for i, ((g0, g1), dist) in enumerate(zip(contact.geom.tolist(), contact.dist.tolist(),
                                                 strict=True)):
            body0 = geom_body[g0]
            robot_body = geom_body[g1] if body0 in floor else body0
            if robot_body in feet:
                mujoco.mj_contactForce(self.model, data, i, wrench)
                forces[feet.index(robot_body)] += float(wrench[0])
            elif dist < 0.0:
                non_foot = True
        return forces, non_foot
