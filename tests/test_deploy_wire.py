"""The fast wire codec: byte-equal to cyclonedds' serialiser, CRC-equal to protocol.crc,
and the joint ↔ motor-slot map."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.deploy import protocol as p
from hybrid_recovery.deploy import wire
from hybrid_recovery.deploy.robot_io import (
    MOTOR_INDEX,
    JointCommand,
    low_cmd_from_command,
    robot_state_from_low_state,
)
from hybrid_recovery.robot import constants

N = constants.NUM_JOINTS


def _random_state_msg(rng: np.random.Generator) -> p.LowState_:
    """A LowState_ with every field random (pads excepted), CRC set."""
    msg = p.default_low_state()
    f32 = lambda *s: rng.normal(size=s).astype(np.float32).tolist()  # noqa: E731
    msg.version = rng.integers(0, 2**32, 2).tolist()
    msg.mode_pr, msg.mode_machine, msg.tick = 1, int(rng.integers(256)), int(rng.integers(2**32))
    imu = msg.imu_state
    imu.quaternion, imu.gyroscope, imu.accelerometer, imu.rpy = f32(4), f32(3), f32(3), f32(3)
    imu.temperature = int(rng.integers(-100, 100))
    for m in msg.motor_state:
        m.mode = int(rng.integers(256))
        m.q, m.dq, m.ddq, m.tau_est, m.vol = f32(5)
        m.temperature = rng.integers(-100, 100, 2).tolist()
        m.sensor = rng.integers(0, 2**32, 2).tolist()
        m.motorstate = int(rng.integers(2**32))
        m.reserve = rng.integers(0, 2**32, 4).tolist()
    msg.wireless_remote = bytes(rng.integers(0, 256, 40).tolist())
    msg.reserve = rng.integers(0, 2**32, 4).tolist()
    return p.with_crc(msg)


def _random_command(rng: np.random.Generator) -> JointCommand:
    f = lambda scale=1.0: (scale * rng.normal(size=N)).astype(np.float32).astype(float)  # noqa: E731
    return JointCommand(q=f(), kp=np.abs(f(100.0)), kd=np.abs(f()), dq=f(), tau=f())


@pytest.fixture(scope="module")
def cyclonedds():
    return pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")


def test_wire_sizes():
    assert wire.STATE_WIRE_SIZE == 4 + 2088 and wire.CMD_WIRE_SIZE == 4 + 1000


@pytest.mark.parametrize("seed", range(3))
def test_state_decoding_and_crc_match_cyclonedds_and_protocol(cyclonedds, seed):
    msg = _random_state_msg(np.random.default_rng(seed))
    data = msg.serialize(use_version_2=False)
    assert wire.zero_pads_ok(data)
    assert wire.state_crc(data) == p.low_state_crc(msg) == msg.crc
    ours = wire.decode_low_state(data, t_receive=1.5)
    ref = robot_state_from_low_state(msg, t_receive=1.5)
    assert ours.crc_ok and (ours.tick, ours.mode_machine) == (ref.tick, ref.mode_machine)
    for name in ("quat", "gyro", "q", "dq", "tau_est"):
        np.testing.assert_array_equal(getattr(ours, name), getattr(ref, name))


def test_state_encoding_is_byte_equal_to_cyclonedds(cyclonedds):
    rng = np.random.default_rng(7)
    q, dq, tau = rng.normal(size=(3, N)).astype(np.float32)
    quat, gyro = rng.normal(size=4).astype(np.float32), rng.normal(size=3).astype(np.float32)
    acc, rpy = rng.normal(size=(2, 3)).astype(np.float32)
    data = wire.encode_low_state(2**32 + 5, quat, gyro, q, dq, tau, acc, rpy, mode_machine=9)
    msg = p.default_low_state()
    msg.tick, msg.mode_machine = 5, 9  # the tick wraps at 2³²
    imu = msg.imu_state
    imu.quaternion, imu.gyroscope = quat.tolist(), gyro.tolist()
    imu.accelerometer, imu.rpy = acc.tolist(), rpy.tolist()
    for i, slot in enumerate(MOTOR_INDEX):
        m = msg.motor_state[slot]
        m.mode, m.q, m.dq, m.tau_est = 1, float(q[i]), float(dq[i]), float(tau[i])
    assert data == p.with_crc(msg).serialize(use_version_2=False)
    assert p.LowState_.deserialize(data).crc == p.low_state_crc(msg)


@pytest.mark.parametrize("seed", range(3))
def test_command_encoding_is_byte_equal_and_round_trips(cyclonedds, seed):
    cmd = _random_command(np.random.default_rng(seed))
    data = wire.encode_low_cmd(cmd, mode_machine=4)
    msg = low_cmd_from_command(cmd, mode_machine=4)
    assert data == msg.serialize(use_version_2=False)
    assert p.crc_ok(p.LowCmd_.deserialize(data))
    back, mode_machine, crc_ok = wire.decode_low_cmd(data)
    assert crc_ok and mode_machine == 4
    for name in ("q", "kp", "kd", "dq", "tau"):
        np.testing.assert_array_equal(getattr(back, name), getattr(cmd, name))


def test_motor_map_uses_slots_0_to_26_and_disables_the_rest():
    np.testing.assert_array_equal(MOTOR_INDEX, np.arange(N))
    cmd = JointCommand(q=np.arange(N) / 10, kp=np.full(N, 50.0), kd=np.ones(N))
    msg = low_cmd_from_command(cmd)
    assert msg.mode_pr == 0
    for i, name in enumerate(constants.JOINT_NAMES):
        slot = msg.motor_cmd[MOTOR_INDEX[i]]
        assert slot.mode == 1 and slot.q == pytest.approx(i / 10), name
    for slot in msg.motor_cmd[N:]:
        assert (slot.mode, slot.q, slot.kp, slot.kd, slot.tau) == (0, 0.0, 0.0, 0.0, 0.0)


def test_a_flipped_bit_fails_the_crc_and_a_disabled_motor_reads_limp():
    cmd = _random_command(np.random.default_rng(3))
    data = bytearray(wire.encode_low_cmd(cmd))
    data[4 + 4 + 28 * 5 + 12] ^= 0x10  # motor 5's kp
    assert not wire.decode_low_cmd(bytes(data))[2]
    msg = low_cmd_from_command(cmd)
    msg.motor_cmd[3].mode = 0
    back, _, crc_ok = wire.decode_low_cmd(_serialize(p.with_crc(msg)))
    assert crc_ok and back.kp[3] == 0.0 and back.q[3] == 0.0 and back.kp[4] == cmd.kp[4]


def _serialize(msg) -> bytes:
    pytest.importorskip("cyclonedds")
    return msg.serialize(use_version_2=False)


def test_malformed_data_is_refused_with_its_size():
    with pytest.raises(ValueError, match=r"^LowState_ wire data must be 2092 bytes starting "
                                         r"with XCDR1-LE header 00010000, got 12 bytes"):
        wire.decode_low_state(b"\x00\x01\x00\x00" + bytes(8))


def test_the_fast_link_self_check_passes(cyclonedds):
    from hybrid_recovery.deploy.fast_dds import check_wire_format

    check_wire_format()
