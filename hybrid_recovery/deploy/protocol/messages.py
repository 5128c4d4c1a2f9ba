"""The Unitree ``unitree_hg`` low-level messages ``LowCmd_`` and ``LowState_`` (H1-2, G1).

Field names, order and types follow Unitree's IDL (``unitree_hg::msg::dds_``), so a DDS
peer using Unitree's SDK recognises the types. The 8-bit fields are ``octet``
(``types.byte``), as the C++ SDK (``unitree_sdk2``) declares them: with cyclonedds 11,
``types.uint8`` is another XTypes kind (``TK_UINT8``, not ``TK_BYTE``), and a C++ reader
would never match a writer of these types. Both serialise to the same bytes. The classes
are cyclonedds IDL dataclasses when cyclonedds is installed (optional extra ``deploy``);
without it they are plain dataclasses with the same fields, enough to build, pack and
CRC messages offline.

Units: joint positions ``q`` rad, velocities ``dq`` rad/s, torques ``tau`` N·m, gains
``kp`` N·m/rad and ``kd`` N·m·s/rad; IMU ``quaternion`` (w, x, y, z), ``gyroscope`` rad/s,
``accelerometer`` m/s², ``rpy`` rad.
"""

from dataclasses import dataclass
from typing import Annotated

try:
    from cyclonedds.idl import IdlStruct, types
    from cyclonedds.idl import annotations as annotate

    HAVE_CYCLONEDDS = True
except ImportError:  # cyclonedds is the optional extra `deploy`: plain dataclasses instead
    HAVE_CYCLONEDDS = False

    class IdlStruct:  # type: ignore[no-redef]
        """Stand-in base class: records the IDL type name only."""

        __idl_typename__: str

        def __init_subclass__(cls, typename: str = "", **kwargs: object) -> None:
            super().__init_subclass__(**kwargs)
            cls.__idl_typename__ = typename or cls.__name__

    class _Array:
        def __init__(self, subtype: object, length: int) -> None:
            self.subtype, self.length = subtype, length

    class types:  # type: ignore[no-redef]
        """Stand-in for ``cyclonedds.idl.types``: Python types of the IDL primitives."""

        byte = int
        uint8 = int
        int16 = int
        uint32 = int
        float32 = float
        array = _Array

    class annotate:  # type: ignore[no-redef]
        """Stand-in for ``cyclonedds.idl.annotations``: no-op decorators."""

        @staticmethod
        def final(cls: type) -> type:
            return cls

        @staticmethod
        def autoid(kind: str) -> object:
            return lambda cls: cls


NUM_MOTORS = 35
"""Motor slots in every ``unitree_hg`` message; the H1-2 uses the first 27."""

_MODULE = "unitree_hg.msg.dds_"  # cyclonedds writes '.' as '::' on the wire


@dataclass
@annotate.final
@annotate.autoid("sequential")
class MotorCmd_(IdlStruct, typename=f"{_MODULE}.MotorCmd_"):
    """One motor's command: τ = tau + kp (q − q_m) + kd (dq − dq_m)."""

    mode: types.byte
    q: types.float32
    dq: types.float32
    tau: types.float32
    kp: types.float32
    kd: types.float32
    reserve: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class LowCmd_(IdlStruct, typename=f"{_MODULE}.LowCmd_"):
    """Low-level command, topic ``rt/lowcmd``; ``motor_cmd`` has 35 entries."""

    mode_pr: types.byte
    mode_machine: types.byte
    motor_cmd: Annotated[list[MotorCmd_], types.array(MotorCmd_, NUM_MOTORS)]
    reserve: Annotated[list[int], types.array(types.uint32, 4)]
    crc: types.uint32


@dataclass
@annotate.final
@annotate.autoid("sequential")
class IMUState_(IdlStruct, typename=f"{_MODULE}.IMUState_"):
    """Torso IMU: quaternion (w, x, y, z), gyroscope rad/s, accelerometer m/s², rpy rad."""

    quaternion: Annotated[list[float], types.array(types.float32, 4)]
    gyroscope: Annotated[list[float], types.array(types.float32, 3)]
    accelerometer: Annotated[list[float], types.array(types.float32, 3)]
    rpy: Annotated[list[float], types.array(types.float32, 3)]
    temperature: types.int16


@dataclass
@annotate.final
@annotate.autoid("sequential")
class MotorState_(IdlStruct, typename=f"{_MODULE}.MotorState_"):
    """One motor's measured state: q rad, dq rad/s, ddq rad/s², tau_est N·m, vol V."""

    mode: types.byte
    q: types.float32
    dq: types.float32
    ddq: types.float32
    tau_est: types.float32
    temperature: Annotated[list[int], types.array(types.int16, 2)]
    vol: types.float32
    sensor: Annotated[list[int], types.array(types.uint32, 2)]
    motorstate: types.uint32
    reserve: Annotated[list[int], types.array(types.uint32, 4)]


@dataclass
@annotate.final
@annotate.autoid("sequential")
class LowState_(IdlStruct, typename=f"{_MODULE}.LowState_"):
    """Low-level state, topic ``rt/lowstate``; ``motor_state`` has 35 entries.

    ``wireless_remote`` holds the remote's 40 raw bytes (``bytes``, as cyclonedds reads
    ``octet`` arrays); ``tick`` is the robot's increasing counter.
    """

    version: Annotated[list[int], types.array(types.uint32, 2)]
    mode_pr: types.byte
    mode_machine: types.byte
    tick: types.uint32
    imu_state: IMUState_
    motor_state: Annotated[list[MotorState_], types.array(MotorState_, NUM_MOTORS)]
    wireless_remote: Annotated[bytes, types.array(types.byte, 40)]
    reserve: Annotated[list[int], types.array(types.uint32, 4)]
    crc: types.uint32


def default_motor_cmd() -> MotorCmd_:
    """An all-zero motor command (zero gains and torque: the motor is limp)."""
    return MotorCmd_(mode=0, q=0.0, dq=0.0, tau=0.0, kp=0.0, kd=0.0, reserve=0)


def default_low_cmd() -> LowCmd_:
    """An all-zero ``LowCmd_`` (crc 0, not yet valid: see ``crc.with_crc``)."""
    return LowCmd_(
        mode_pr=0,
        mode_machine=0,
        motor_cmd=[default_motor_cmd() for _ in range(NUM_MOTORS)],
        reserve=[0] * 4,
        crc=0,
    )


def default_imu_state() -> IMUState_:
    """An all-zero IMU state (note: the zero quaternion is not a rotation)."""
    return IMUState_(
        quaternion=[0.0] * 4,
        gyroscope=[0.0] * 3,
        accelerometer=[0.0] * 3,
        rpy=[0.0] * 3,
        temperature=0,
    )


def default_motor_state() -> MotorState_:
    """An all-zero motor state."""
    return MotorState_(
        mode=0,
        q=0.0,
        dq=0.0,
        ddq=0.0,
        tau_est=0.0,
        temperature=[0, 0],
        vol=0.0,
        sensor=[0, 0],
        motorstate=0,
        reserve=[0] * 4,
    )


def default_low_state() -> LowState_:
    """An all-zero ``LowState_`` (crc 0, not yet valid: see ``crc.with_crc``)."""
    return LowState_(
        version=[0, 0],
        mode_pr=0,
        mode_machine=0,
        tick=0,
        imu_state=default_imu_state(),
        motor_state=[default_motor_state() for _ in range(NUM_MOTORS)],
        wireless_remote=bytes(40),  # cyclonedds reads octet arrays as bytes
        reserve=[0] * 4,
        crc=0,
    )
