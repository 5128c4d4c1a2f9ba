"""What the controller reads from and writes to the robot, in joint order, and the motor map.

The ``unitree_hg`` messages carry 35 motor slots; the H1-2 uses slots 0–26 in the order of
``constants.JOINT_NAMES`` (the robot's motor order), so joint i lives in motor slot
``MOTOR_INDEX[i]``; slots 27–34 are sent disabled (mode 0, all zero).

The IMU in ``LowState_.imu_state`` is the torso IMU of the H1-2 (on ``torso_link``, not the
pelvis): quaternion (w, x, y, z) of the IMU frame in the world, gyroscope in the IMU frame.
The policy is trained on exactly these quantities (the env's ``imu`` site on torso_link:
MuJoCo ``gyro`` + ``framequat``), so no frame conversion is applied.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hybrid_recovery.deploy.protocol import (
    NUM_MOTORS,
    LowCmd_,
    LowState_,
    default_low_cmd,
    with_crc,
)
from hybrid_recovery.robot import constants

MOTOR_INDEX = np.array([i for i, _ in enumerate(constants.JOINT_NAMES)])
"""Motor slot of each joint, shape (27,): ``constants.JOINT_NAMES`` is the motor order."""

MODE_PR = 0
"""``LowCmd_.mode_pr`` = 0: ankles commanded as (pitch, roll) joints, as in our model."""

assert len(MOTOR_INDEX) <= NUM_MOTORS and len(set(MOTOR_INDEX.tolist())) == len(MOTOR_INDEX)


@dataclass(frozen=True)
class LowStateReading:
    """One ``LowState_`` in joint order.

    Attributes:
        tick: The robot's increasing counter.
        quat: Torso IMU orientation (w, x, y, z), shape (4,).
        gyro: Torso IMU angular velocity in the IMU frame, shape (3,) [rad/s].
        q: Joint positions, shape (27,) [rad].
        dq: Joint velocities, shape (27,) [rad/s].
        tau_est: Motor torque estimates, shape (27,) [N·m].
        mode_machine: The robot's ``mode_machine``, echoed in every command.
        t_receive: Arrival time, ``time.monotonic()`` [s] (or simulation time).
        crc_ok: Whether the message's CRC was valid.
    """

    tick: int
    quat: np.ndarray
    gyro: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    tau_est: np.ndarray
    mode_machine: int = 0
    t_receive: float = 0.0
    crc_ok: bool = True

    def is_finite(self) -> bool:
        """Whether every float of the state is finite."""
        return bool(all(np.isfinite(a).all() for a in (self.quat, self.gyro, self.q, self.dq,
                                                          self.tau_est)))


def _zeros() -> np.ndarray:
    return np.zeros(constants.NUM_JOINTS)


@dataclass(frozen=True)
class JointCommand:
    """A motor-driver command in joint order: τ = tau + kp (q − q_m) + kd (dq − dq_m).

    Attributes:
        q: Position targets q_ref, shape (27,) [rad].
        kp: Stiffness, shape (27,) [N·m/rad].
        kd: Damping, shape (27,) [N·m·s/rad].
        dq: Velocity targets, shape (27,) [rad/s] (0 here).
        tau: Feed-forward torques, shape (27,) [N·m] (0 here).
    """

    q: np.ndarray = field(default_factory=_zeros)
    kp: np.ndarray = field(default_factory=_zeros)
    kd: np.ndarray = field(default_factory=_zeros)
    dq: np.ndarray = field(default_factory=_zeros)
    tau: np.ndarray = field(default_factory=_zeros)

    def torque(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """The driver's torque at (q, dq), before its effort clip, shape (27,) [N·m]."""
        return self.tau + self.kp * (self.q - q) + self.kd * (self.dq - dq)


def robot_state_from_low_state(msg: LowState_, t_receive: float = 0.0,
                               crc_ok: bool = True) -> LowStateReading:
    """A :class:`LowStateReading` from a ``LowState_`` object (the slow, object-based path)."""
    motors = [msg.motor_state[i] for i in MOTOR_INDEX]
    return LowStateReading(
        tick=int(msg.tick), quat=np.array(msg.imu_state.quaternion, dtype=float),
        gyro=np.array(msg.imu_state.gyroscope, dtype=float),
        q=np.array([m.q for m in motors]), dq=np.array([m.dq for m in motors]),
        tau_est=np.array([m.tau_est for m in motors]), mode_machine=int(msg.mode_machine),
        t_receive=t_receive, crc_ok=crc_ok)


def low_cmd_from_command(cmd: JointCommand, mode_machine: int = 0) -> LowCmd_:
    """A ``LowCmd_`` with a valid CRC: joint i in slot ``MOTOR_INDEX[i]`` with mode 1."""
    msg = default_low_cmd()
    msg.mode_pr, msg.mode_machine = MODE_PR, int(mode_machine)
    for i, slot in enumerate(MOTOR_INDEX):
        m = msg.motor_cmd[slot]
        m.mode = 1
        m.q, m.dq, m.tau = float(cmd.q[i]), float(cmd.dq[i]), float(cmd.tau[i])
        m.kp, m.kd = float(cmd.kp[i]), float(cmd.kd[i])
    return with_crc(msg)
