"""C-layout packing and the CRC-32 of the ``unitree_hg`` low-level messages.

The robot checks a CRC computed over the raw memory of its C structs, so the messages are
packed little-endian with the C compiler's natural alignment (explicit ``x`` pad bytes,
always zero here):

* ``MotorCmd_``   ``B3x 5f I``              28 bytes
* ``LowCmd_``     ``2B2x 35×MotorCmd_ 4I I``  1004 bytes (250 u32 words + crc)
* ``IMUState_``   ``13f h2x``               56 bytes
* ``MotorState_`` ``B3x 4f 2h f 2I I 4I``   56 bytes
* ``LowState_``   ``2I 2B2x I IMUState_ 35×MotorState_ 40B 4I I``  2092 bytes (522 + crc)

The CRC runs over the u32 words before the trailing ``crc`` field, each word fed MSB first
(bit 31 … bit 0): polynomial 0x04C11DB7, initial value 0xFFFFFFFF, no reflection, no final
xor. That is CRC-32/MPEG-2 over the words' big-endian bytes, computed here with zlib's
reflected CRC-32 on bit-reversed bytes: MPEG2(x) = rev32(~zlib.crc32(rev8(x))).
"""

from __future__ import annotations

import struct
import sys
import zlib
from array import array
from collections.abc import Iterator, Sequence
from itertools import islice
from typing import TypeVar

import numpy as np

from hybrid_recovery.deploy.protocol.messages import (
    NUM_MOTORS,
    IMUState_,
    LowCmd_,
    LowState_,
    MotorCmd_,
    MotorState_,
)

_MOTOR_CMD_FMT = "B3x5fI"
_IMU_STATE_FMT = "13fh2x"
_MOTOR_STATE_FMT = "B3x4f2hf2II4I"
_LOW_CMD = struct.Struct("<2B2x" + _MOTOR_CMD_FMT * NUM_MOTORS + "4I" + "I")
_LOW_STATE = struct.Struct(
    "<2I2B2xI" + _IMU_STATE_FMT + _MOTOR_STATE_FMT * NUM_MOTORS + "40B4I" + "I"
)

MOTOR_CMD_SIZE = struct.calcsize("<" + _MOTOR_CMD_FMT)
"""Bytes of a C ``MotorCmd_``: 28."""
MOTOR_STATE_SIZE = struct.calcsize("<" + _MOTOR_STATE_FMT)
"""Bytes of a C ``MotorState_``: 56."""
IMU_STATE_SIZE = struct.calcsize("<" + _IMU_STATE_FMT)
"""Bytes of a C ``IMUState_``: 56."""
LOW_CMD_SIZE = _LOW_CMD.size
"""Bytes of a C ``LowCmd_``: 1004."""
LOW_STATE_SIZE = _LOW_STATE.size
"""Bytes of a C ``LowState_``: 2092."""

assert array("I").itemsize == 4, "array('I') must hold u32 words"
_BITREV8 = bytes(int(f"{i:08b}"[::-1], 2) for i in range(256))
_Msg = TypeVar("_Msg", LowCmd_, LowState_)


def crc32_words(words: Sequence[int] | np.ndarray) -> int:
    """CRC-32 of u32 words fed MSB first (poly 0x04C11DB7, init 0xFFFFFFFF, no xorout).

    Args:
        words: The u32 words, shape (n,).

    Returns:
        The CRC, an int in [0, 2³²).
    """
    return _crc32_be_bytes(np.asarray(words, dtype=">u4").tobytes())


def _crc32_le_bytes(data: bytes) -> int:
    """``crc32_words`` of the little-endian words in ``data`` (length a multiple of 4)."""
    words = array("I", data)  # native order; array is ~1 µs faster than numpy here
    if sys.byteorder == "little":
        words.byteswap()
    return _crc32_be_bytes(words.tobytes())


def _crc32_be_bytes(data: bytes) -> int:
    """CRC-32/MPEG-2 of ``data`` via zlib's reflected CRC-32 on bit-reversed bytes."""
    reflected = zlib.crc32(data.translate(_BITREV8)) ^ 0xFFFFFFFF
    return int(f"{reflected:032b}"[::-1], 2)


def _check_motors(name: str, motors: Sequence[object]) -> None:
    if len(motors) != NUM_MOTORS:
        raise ValueError(f"{name} must have {NUM_MOTORS} entries, got {len(motors)}")


def pack_low_cmd(msg: LowCmd_) -> bytes:
    """Pack a ``LowCmd_`` as its C struct (little-endian, padded). Length 1004."""
    _check_motors("LowCmd_.motor_cmd", msg.motor_cmd)
    values: list[int | float] = [msg.mode_pr, msg.mode_machine]
    for m in msg.motor_cmd:
        values += (m.mode, m.q, m.dq, m.tau, m.kp, m.kd, m.reserve)
    values += msg.reserve
    values.append(msg.crc)
    return _LOW_CMD.pack(*values)


def pack_low_state(msg: LowState_) -> bytes:
    """Pack a ``LowState_`` as its C struct (little-endian, padded). Length 2092."""
    _check_motors("LowState_.motor_state", msg.motor_state)
    imu = msg.imu_state
    values: list[int | float] = [*msg.version, msg.mode_pr, msg.mode_machine, msg.tick]
    values += (*imu.quaternion, *imu.gyroscope, *imu.accelerometer, *imu.rpy, imu.temperature)
    for m in msg.motor_state:
        values += (m.mode, m.q, m.dq, m.ddq, m.tau_est, *m.temperature, m.vol)
        values += (*m.sensor, m.motorstate, *m.reserve)
    values += (*msg.wireless_remote, *msg.reserve, msg.crc)
    return _LOW_STATE.pack(*values)


def _take(it: Iterator, n: int) -> list:
    return list(islice(it, n))


def _check_size(name: str, data: bytes, size: int) -> None:
    if len(data) != size:
        raise ValueError(f"{name} packs to {size} bytes, got {len(data)}")


def unpack_low_cmd(data: bytes) -> LowCmd_:
    """Inverse of ``pack_low_cmd``: a ``LowCmd_`` from its 1004-byte C struct."""
    _check_size("LowCmd_", data, LOW_CMD_SIZE)
    it = iter(_LOW_CMD.unpack(data))
    mode_pr, mode_machine = _take(it, 2)
    motors = [MotorCmd_(*_take(it, 7)) for _ in range(NUM_MOTORS)]
    reserve = _take(it, 4)
    return LowCmd_(mode_pr, mode_machine, motors, reserve, next(it))


def _unpack_motor_state(it: Iterator) -> MotorState_:
    mode, q, dq, ddq, tau_est = _take(it, 5)
    temperature, (vol,), sensor = _take(it, 2), _take(it, 1), _take(it, 2)
    motorstate, reserve = next(it), _take(it, 4)
    return MotorState_(mode, q, dq, ddq, tau_est, temperature, vol, sensor, motorstate, reserve)


def unpack_low_state(data: bytes) -> LowState_:
    """Inverse of ``pack_low_state``: a ``LowState_`` from its 2092-byte C struct."""
    _check_size("LowState_", data, LOW_STATE_SIZE)
    it = iter(_LOW_STATE.unpack(data))
    version, (mode_pr, mode_machine, tick) = _take(it, 2), _take(it, 3)
    imu = IMUState_(_take(it, 4), _take(it, 3), _take(it, 3), _take(it, 3), next(it))
    motors = [_unpack_motor_state(it) for _ in range(NUM_MOTORS)]
    wireless_remote, reserve = bytes(_take(it, 40)), _take(it, 4)
    return LowState_(
        version, mode_pr, mode_machine, tick, imu, motors, wireless_remote, reserve, next(it)
    )


def low_cmd_crc(msg: LowCmd_) -> int:
    """The CRC the robot expects in ``msg.crc`` (the current ``msg.crc`` is ignored)."""
    return _crc32_le_bytes(pack_low_cmd(msg)[:-4])


def low_state_crc(msg: LowState_) -> int:
    """The CRC the robot writes into ``msg.crc`` (the current ``msg.crc`` is ignored)."""
    return _crc32_le_bytes(pack_low_state(msg)[:-4])


def _crc_of(msg: LowCmd_ | LowState_) -> int:
    if isinstance(msg, LowCmd_):
        return low_cmd_crc(msg)
    if isinstance(msg, LowState_):
        return low_state_crc(msg)
    raise TypeError(f"expected LowCmd_ or LowState_, got {type(msg).__name__}")


def with_crc(msg: _Msg) -> _Msg:
    """Set ``msg.crc`` in place to its correct value and return ``msg``."""
    msg.crc = _crc_of(msg)
    return msg


def crc_ok(msg: LowCmd_ | LowState_) -> bool:
    """Whether ``msg.crc`` matches the message's contents."""
    expected = _crc_of(msg)
    return msg.crc == expected
