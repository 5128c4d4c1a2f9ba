"""The ``unitree_hg`` messages: C layout, CRC golden values, pack round trips, bit flips."""

import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hybrid_recovery.deploy.protocol import (
    IMU_STATE_SIZE,
    LOW_CMD_SIZE,
    LOW_STATE_SIZE,
    MOTOR_CMD_SIZE,
    MOTOR_STATE_SIZE,
    NUM_MOTORS,
    IMUState_,
    LowCmd_,
    LowState_,
    MotorCmd_,
    MotorState_,
    crc32_words,
    crc_ok,
    default_low_cmd,
    default_low_state,
    low_cmd_crc,
    low_state_crc,
    pack_low_cmd,
    pack_low_state,
    unpack_low_cmd,
    unpack_low_state,
    with_crc,
)
from hybrid_recovery.deploy.protocol.crc import _crc32_be_bytes

ROOT = Path(__file__).resolve().parents[1]
GOLDEN_LOW_CMD_CRC = 4262932383
GOLDEN_LOW_STATE_CRC = 3595284554


def crc32_words_bitwise(words: list[int]) -> int:
    """Independent reference: the shift-register loop, one bit at a time, MSB first."""
    crc = 0xFFFFFFFF
    for word in words:
        for bit in range(31, -1, -1):
            feedback = (crc >> 31) ^ ((word >> bit) & 1)
            crc = (crc << 1) & 0xFFFFFFFF
            if feedback:
                crc ^= 0x04C11DB7
    return crc


def _f32(rng: np.random.Generator, n: int) -> list[float]:
    return [float(x) for x in rng.normal(scale=10.0, size=n).astype(np.float32)]


def _u(rng: np.random.Generator, bits: int, n: int) -> list[int]:
    return [int(x) for x in rng.integers(0, 2**bits, size=n, dtype=np.uint64)]


def random_low_cmd(rng: np.random.Generator) -> LowCmd_:
    motors = [MotorCmd_(_u(rng, 8, 1)[0], *_f32(rng, 5), _u(rng, 32, 1)[0]) for _ in range(35)]
    return LowCmd_(*_u(rng, 8, 2), motors, _u(rng, 32, 4), _u(rng, 32, 1)[0])


def random_low_state(rng: np.random.Generator) -> LowState_:
    i16 = [int(x) for x in rng.integers(-(2**15), 2**15, size=1 + 2 * NUM_MOTORS)]
    imu = IMUState_(_f32(rng, 4), _f32(rng, 3), _f32(rng, 3), _f32(rng, 3), i16[0])
    motors = [
        MotorState_(
            _u(rng, 8, 1)[0],
            *_f32(rng, 4),
            i16[1 + 2 * k : 3 + 2 * k],
            _f32(rng, 1)[0],
            _u(rng, 32, 2),
            _u(rng, 32, 1)[0],
            _u(rng, 32, 4),
        )
        for k in range(NUM_MOTORS)
    ]
    return LowState_(
        _u(rng, 32, 2),
        *_u(rng, 8, 2),
        _u(rng, 32, 1)[0],
        imu,
        motors,
        bytes(_u(rng, 8, 40)),
        _u(rng, 32, 4),
        _u(rng, 32, 1)[0],
    )


def test_packed_sizes_are_the_c_struct_sizes() -> None:
    assert (MOTOR_CMD_SIZE, MOTOR_STATE_SIZE, IMU_STATE_SIZE) == (28, 56, 56)
    assert LOW_CMD_SIZE == 4 + 35 * 28 + 16 + 4 == 1004
    assert LOW_STATE_SIZE == 16 + 56 + 35 * 56 + 40 + 16 + 4 == 2092
    assert len(pack_low_cmd(default_low_cmd())) == LOW_CMD_SIZE
    assert len(pack_low_state(default_low_state())) == LOW_STATE_SIZE


def test_field_offsets_follow_c_alignment() -> None:
    cmd = default_low_cmd()
    cmd.mode_machine, cmd.motor_cmd[1].q, cmd.reserve[0], cmd.crc = 5, 1.5, 7, 9
    data = pack_low_cmd(cmd)
    assert data[1] == 5
    assert struct.unpack_from("<f", data, 4 + 28 + 4)[0] == 1.5  # motor 1 q after 3 pad bytes
    assert struct.unpack_from("<2I", data, 4 + 35 * 28) == (7, 0)
    assert struct.unpack_from("<I", data, 1000)[0] == 9
    state = default_low_state()
    state.tick, state.imu_state.temperature, state.motor_state[0].vol = 11, -3, 2.5
    data = pack_low_state(state)
    assert struct.unpack_from("<I", data, 12)[0] == 11
    assert struct.unpack_from("<h", data, 16 + 52)[0] == -3
    assert struct.unpack_from("<f", data, 16 + 56 + 24)[0] == 2.5


def test_golden_crc_of_default_messages() -> None:
    assert low_cmd_crc(default_low_cmd()) == GOLDEN_LOW_CMD_CRC
    assert low_state_crc(default_low_state()) == GOLDEN_LOW_STATE_CRC


def test_crc_is_crc32_mpeg2_check_value() -> None:
    assert _crc32_be_bytes(b"123456789") == 0x0376E6E7  # the CRC catalogue's check value


def test_crc32_words_matches_bitwise_reference() -> None:
    rng = np.random.default_rng(0)
    for n in (0, 1, 2, 7, 250):
        words = _u(rng, 32, n)
        assert crc32_words(words) == crc32_words_bitwise(words)
        assert crc32_words(np.array(words, dtype=np.uint32)) == crc32_words_bitwise(words)


def test_message_crc_matches_bitwise_reference_on_random_messages() -> None:
    rng = np.random.default_rng(1)
    cmd, state = random_low_cmd(rng), random_low_state(rng)
    cmd_words = list(struct.unpack(f"<{LOW_CMD_SIZE // 4}I", pack_low_cmd(cmd)))[:-1]
    state_words = list(struct.unpack(f"<{LOW_STATE_SIZE // 4}I", pack_low_state(state)))[:-1]
    assert low_cmd_crc(cmd) == crc32_words_bitwise(cmd_words)
    assert low_state_crc(state) == crc32_words_bitwise(state_words)


@pytest.mark.parametrize("make", [random_low_cmd, random_low_state])
def test_pack_unpack_round_trip(make) -> None:
    rng = np.random.default_rng(2)
    for _ in range(5):
        msg = make(rng)
        if isinstance(msg, LowCmd_):
            assert unpack_low_cmd(pack_low_cmd(msg)) == msg
        else:
            assert unpack_low_state(pack_low_state(msg)) == msg


@pytest.mark.parametrize("kind", ["cmd", "state"])
def test_crc_ok_detects_every_sampled_single_bit_flip(kind: str) -> None:
    rng = np.random.default_rng(3)
    if kind == "cmd":
        msg, pack, unpack = with_crc(random_low_cmd(rng)), pack_low_cmd, unpack_low_cmd
    else:
        msg, pack, unpack = with_crc(random_low_state(rng)), pack_low_state, unpack_low_state
    assert crc_ok(msg)
    data = pack(msg)
    checked = 0
    for bit in rng.choice((len(data) - 4) * 8, size=300, replace=False):
        flipped = bytearray(data)
        flipped[bit // 8] ^= 1 << (bit % 8)
        corrupt = unpack(bytes(flipped))
        if pack(corrupt) != flipped:  # a padding bit, or a NaN payload Python normalises
            continue
        assert not crc_ok(corrupt), f"flip of bit {bit} not detected"
        checked += 1
    assert checked > 250


def test_with_crc_sets_the_field_in_place() -> None:
    cmd = default_low_cmd()
    assert with_crc(cmd) is cmd
    assert cmd.crc == GOLDEN_LOW_CMD_CRC and crc_ok(cmd)
    cmd.motor_cmd[0].kp = 100.0
    assert not crc_ok(cmd)


def test_validation_messages() -> None:
    with pytest.raises(ValueError, match=r"^LowCmd_ packs to 1004 bytes, got 1000$"):
        unpack_low_cmd(bytes(1000))
    with pytest.raises(ValueError, match=r"^LowState_ packs to 2092 bytes, got 0$"):
        unpack_low_state(b"")
    cmd = default_low_cmd()
    cmd.motor_cmd = cmd.motor_cmd[:27]
    with pytest.raises(ValueError, match=r"^LowCmd_.motor_cmd must have 35 entries, got 27$"):
        pack_low_cmd(cmd)
    with pytest.raises(TypeError, match=r"^expected LowCmd_ or LowState_, got int$"):
        crc_ok(3)


def test_idl_type_names_are_unitrees() -> None:
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    for cls in (MotorCmd_, LowCmd_, IMUState_, MotorState_, LowState_):
        name = cls.__idl__.idl_transformed_typename
        assert name == f"unitree_hg::msg::dds_::{cls.__name__}"


UNITREE_SDK2_TYPE_IDS = {
    "MotorCmd_": ("827f55de9b9de38c62bacd1e56c9", "a2d9ced50a7956e2a607613a13f1"),
    "MotorState_": ("7cc584ed940b8f3018f18de0ed24", "a86cbab3ae0aa98a1e746643a099"),
    "IMUState_": ("fc687176651206558473df442280", "7d4166754177d86fa27cd25b0403"),
}
"""XTypes type identifiers (the 14-byte equivalence hashes of the minimal and complete
TypeObjects) of Unitree's C++ SDK: the ``type_map_blob`` of the headers that cyclonedds'
idlc generated in unitree_sdk2, ``include/unitree/idl/hg/HandCmd_.hpp`` (MotorCmd_) and
``HandState_.hpp`` (MotorState_, IMUState_). A reader and a writer match only when these
agree (with type information, as cyclonedds 11 exchanges it)."""

TK_BYTE, TK_UINT8 = 0x02, 0x0D
"""XTypes 1.3 type kinds of ``octet`` and ``uint8``."""


@pytest.mark.parametrize("cls", [MotorCmd_, MotorState_, IMUState_], ids=lambda c: c.__name__)
def test_type_identity_is_the_cpp_sdks(cls) -> None:
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    info = cls.__idl__.get_type_info()
    minimal = info.minimal.typeid_with_size.type_id
    complete = info.complete.typeid_with_size.type_id
    assert (minimal.discriminator, complete.discriminator) == (0xF1, 0xF2)  # EK_MINIMAL/COMPLETE
    assert (minimal.value.hex(), complete.value.hex()) == UNITREE_SDK2_TYPE_IDS[cls.__name__]


def _member_kinds(cls) -> dict:
    """Member name hash → type kind, from the minimal TypeObject (arrays: element kind)."""
    pair = cls.__idl__.get_type_mapping().identifier_object_pair_minimal[0]
    kinds = {}
    for member in pair.type_object.minimal.struct_type.member_seq:
        type_id = member.common.member_type_id
        if type_id.discriminator == 0x90:  # TI_PLAIN_ARRAY_SMALL
            type_id = type_id.value.element_identifier
        kinds[member.common.member_id] = type_id.discriminator
    return kinds


def test_every_8_bit_field_is_an_octet_with_unchanged_bytes() -> None:
    """``LowCmd_.mode_pr, mode_machine``, ``LowState_.mode_pr, mode_machine,
    wireless_remote`` are ``octet`` like ``MotorCmd_.mode`` and ``MotorState_.mode`` (whose
    whole types match the C++ SDK above); declared ``uint8`` they would serialise to the
    same bytes but be another type.

    (No ``from __future__ import annotations`` in this file: cyclonedds would have to
    resolve these local classes from string annotations.)
    """
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    from dataclasses import dataclass

    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl import annotations as annotate
    from cyclonedds.idl import types as t

    assert [_member_kinds(LowCmd_)[i] for i in (0, 1)] == [TK_BYTE, TK_BYTE]
    assert [_member_kinds(LowState_)[i] for i in (1, 2, 6)] == [TK_BYTE] * 3
    assert _member_kinds(MotorCmd_)[0] == _member_kinds(MotorState_)[0] == TK_BYTE

    @dataclass
    @annotate.final
    @annotate.autoid("sequential")
    class Uint8MotorCmd(IdlStruct, typename="unitree_hg.msg.dds_.MotorCmd_"):
        mode: t.uint8
        q: t.float32
        dq: t.float32
        tau: t.float32
        kp: t.float32
        kd: t.float32
        reserve: t.uint32

    @dataclass
    @annotate.final
    @annotate.autoid("sequential")
    class Uint8LowCmd(IdlStruct, typename="unitree_hg.msg.dds_.LowCmd_"):
        mode_pr: t.uint8
        mode_machine: t.uint8
        motor_cmd: t.array[Uint8MotorCmd, 35]
        reserve: t.array[t.uint32, 4]
        crc: t.uint32

    assert _member_kinds(Uint8LowCmd)[0] == TK_UINT8
    assert Uint8LowCmd.__idl__.get_type_id() != LowCmd_.__idl__.get_type_id()
    wire = with_crc(default_low_cmd()).serialize()
    assert len(wire) == 4 + 1000
    assert Uint8LowCmd.deserialize(wire).serialize() == wire  # the same bytes
    assert Uint8LowCmd.deserialize(wire).crc == 4262932383


def test_cdr_round_trip_keeps_crc_valid() -> None:
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    rng = np.random.default_rng(4)
    state = with_crc(random_low_state(rng))
    back = LowState_.deserialize(state.serialize())
    assert back == state and crc_ok(back)


def test_messages_and_crc_work_without_cyclonedds() -> None:
    code = (
        "import sys; sys.modules['cyclonedds'] = None\n"
        "from hybrid_recovery.deploy import protocol as p\n"
        "assert not p.HAVE_CYCLONEDDS\n"
        "assert p.low_cmd_crc(p.default_low_cmd()) == 4262932383\n"
        "assert p.low_state_crc(p.default_low_state()) == 3595284554\n"
        "try:\n    p.DdsChannel(0)\nexcept ImportError as e:\n    print(e)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=30
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == (
        "cyclonedds is required for the DDS transport: pip install 'hybrid_recovery[deploy]'"
    )
