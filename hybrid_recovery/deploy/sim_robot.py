"""A simulated H1-2 that obeys ``LowCmd_`` like the real motor drivers and reports ``LowState_``.

MuJoCo at 1 kHz. Each motor runs the driver's law τ = tau + kp (q_ref − q) + kd (dq_ref − q̇),
clipped to ±τ_max, on the gains of the latest accepted command: actuator i (on
``constants.JOINT_NAMES[i]``) is a MuJoCo position servo whose gain and bias are rewritten
from the command (``gainprm[0] = kp``, ``biasprm = (tau + kd·dq_ref, −kp, −kd)``), so the PD
is integrated exactly as in training and sim-to-sim. Before the first command the motors
are limp. Commands with a bad CRC are rejected and counted; the previous one stays.

The IMU reading is the ``imu`` site on torso_link (the robot's torso IMU): ``framequat``
(w, x, y, z) and ``gyro`` in the IMU frame, as ``LowState_.imu_state``. The accelerometer
is not simulated (zeros); the policy does not read it.

A "gantry" (Unitree's simulator calls it an elastic band) can hold the pelvis for the first
seconds, as a hardware start-up hangs the robot: a spring-damper on the pelvis position and
orientation plus its weight, released after ``gantry_s`` seconds of commands.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.deploy.robot_io import JointCommand, LowStateReading
from hybrid_recovery.deploy.wire import decode_low_cmd, encode_low_state
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import default_qpos
from hybrid_recovery.sim.scene import build_scene


@dataclass
class SimRobotConfig:
    """The simulated robot."""

    model_path: str | None = None
    """H1-2 MJCF; None for the project's own model."""
    physics_dt: float = 0.001
    """[s] (1 kHz)."""
    rotor_inertia: bool = False
    """Give the joints the project's rotor inertia (a file without armature)."""
    gantry_s: float = 0.0
    """Hold the pelvis on the gantry for this long after the first accepted command [s];
    0 starts on the ground."""
    gantry_clearance: float = 0.03
    """Feet above the ground while hanging, in the default pose [m]."""
    gantry_stiffness: float = 20000.0
    """[N/m] and, ×0.05, [N·m/rad]."""
    mode_machine: int = 6
    """Value reported in ``LowState_.mode_machine`` (any constant; echoed by controllers)."""


class SimRobot:
    """The simulated robot: motor-driver PD on the latest command, torso IMU, gantry.

    Args:
        cfg: Configuration; None for the defaults.
        qpos: Initial configuration (nq,); None for the default pose (raised onto the
            gantry if ``cfg.gantry_s`` > 0).
        qvel: Initial velocities (nv,); None for zero.
    """

    def __init__(self, cfg: SimRobotConfig | None = None, qpos: np.ndarray | None = None,
                 qvel: np.ndarray | None = None) -> None:
        self.cfg = cfg = cfg or SimRobotConfig()
        self.model, self.layout = build_scene(cfg.model_path, cfg.physics_dt,
                                              rotor_inertia=cfg.rotor_inertia)
        m = self.model
        self.data = mujoco.MjData(m)
        self.qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in constants.JOINT_NAMES])
        self.dadr = np.array([m.jnt_dofadr[m.joint(n).id] for n in constants.JOINT_NAMES])
        self.pelvis = m.body(constants.PELVIS_BODY).id
        self.torso = m.body(constants.TORSO_BODY).id
        self.mass = float(m.body_subtreemass[self.pelvis])
        start = default_qpos(m)
        if cfg.gantry_s > 0:
            start[2] += cfg.gantry_clearance
        self.data.qpos[:] = start if qpos is None else qpos
        if qvel is not None:
            self.data.qvel[:] = qvel
        self.gantry_target = start[:3].copy()
        self.gantry_on = cfg.gantry_s > 0
        self.tick = 0
        self.accepted = self.rejected = 0
        self.command: JointCommand | None = None
        self.t_first_command: float | None = None
        self.push = np.zeros(3)
        self._set_pd(JointCommand())  # limp until told otherwise
        self.command = None
        mujoco.mj_forward(m, self.data)

    @property
    def time(self) -> float:
        """Simulation time [s]."""
        return float(self.data.time)

    # ------------------------------------------------------------------ commands
    def apply_command(self, cmd: JointCommand) -> None:
        """Sets every motor's PD from ``cmd`` (joint order); the first one starts the gantry
        timer."""
        if self.t_first_command is None:
            self.t_first_command = self.time
        self._set_pd(cmd)

    def _set_pd(self, cmd: JointCommand) -> None:
        m, d = self.model, self.data
        m.actuator_gainprm[:, 0] = cmd.kp
        m.actuator_biasprm[:, 0] = cmd.tau + cmd.kd * cmd.dq
        m.actuator_biasprm[:, 1] = -cmd.kp
        m.actuator_biasprm[:, 2] = -cmd.kd
        d.ctrl[:] = cmd.q
        self.command = cmd

    def apply_command_wire(self, wire: bytes) -> bool:
        """Applies a serialised ``LowCmd_`` if its CRC is valid; returns whether it was."""
        cmd, _, crc_ok = decode_low_cmd(wire)
        if not crc_ok:
            self.rejected += 1
            return False
        self.accepted += 1
        self.apply_command(cmd)
        return True

    # ------------------------------------------------------------------ physics
    def step(self, nstep: int = 1) -> None:
        """Advances ``nstep`` physics steps (the tick counts steps, i.e. milliseconds)."""
        d = self.data
        for _ in range(nstep):
            self._update_gantry()
            d.xfrc_applied[self.torso, :3] = self.push
            mujoco.mj_step(self.model, d)
            self.tick += 1

    def _update_gantry(self) -> None:
        d = self.data
        if self.gantry_on and self.t_first_command is not None and (
                self.time - self.t_first_command >= self.cfg.gantry_s):
            self.gantry_on = False
            d.xfrc_applied[self.pelvis] = 0.0
        if not self.gantry_on:
            return
        k = self.cfg.gantry_stiffness
        c = 2.0 * np.sqrt(k * self.mass)
        force = k * (self.gantry_target - d.qpos[:3]) - c * d.qvel[:3]
        force[2] += self.mass * 9.81
        rotvec = np.zeros(3)  # axis · angle of the base: the same in world and base axes
        mujoco.mju_quat2Vel(rotvec, d.qpos[3:7], 1.0)
        omega_world = d.xmat[self.pelvis].reshape(3, 3) @ d.qvel[3:6]
        torque = -0.05 * k * rotvec - 0.05 * c * omega_world
        d.xfrc_applied[self.pelvis] = np.concatenate([force, torque])

    # ------------------------------------------------------------------ sensing
    def state(self, t_receive: float | None = None) -> LowStateReading:
        """The current :class:`LowStateReading` (sensors as the robot reports them)."""
        d, lay = self.data, self.layout
        mujoco.mj_forward(self.model, d)  # sensors and torques of the current state
        return LowStateReading(
            tick=self.tick, quat=d.sensordata[lay.quat].copy(),
            gyro=d.sensordata[lay.gyro].copy(), q=d.qpos[self.qadr].copy(),
            dq=d.qvel[self.dadr].copy(), tau_est=d.actuator_force.copy(),
            mode_machine=self.cfg.mode_machine,
            t_receive=self.time if t_receive is None else t_receive)

    def state_wire(self) -> bytes:
        """The current state as a serialised ``LowState_`` with a valid CRC."""
        s = self.state()
        return encode_low_state(s.tick, s.quat, s.gyro, s.q, s.dq, s.tau_est,
                                mode_machine=s.mode_machine)

    def base_height(self) -> float:
        """Pelvis height [m]."""
        return float(self.data.qpos[2])

    def torso_tilt_deg(self) -> float:
        """Angle between the torso's z axis and the vertical [deg]."""
        return float(np.degrees(np.arccos(np.clip(self.data.xmat[self.torso][8], -1.0, 1.0))))
