"""The robot loop fails safe: any exception sends damping before it ends the run with
the cause; a non-unit IMU quaternion is a fault; older ticks are ignored (modulo 2³²).

The DDS link is replaced by an in-process fake (same interface as ``FastLink``), so
these run without cyclonedds; ``test_deploy_loopback.py`` covers the real link.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from hybrid_recovery.deploy import bridge
from hybrid_recovery.deploy.bridge import ControllerError, run_controller
from hybrid_recovery.deploy.fast_dds import RawSample
from hybrid_recovery.deploy.robot_io import LowStateReading
from hybrid_recovery.deploy.state_machine import (
    Fault,
    Phase,
    SafetyConfig,
    SafetyStateMachine,
    tick_is_newer,
)
from hybrid_recovery.deploy.wire import decode_low_cmd, encode_low_state
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.training.stand_in import write_stand_in_policy

N = constants.NUM_JOINTS


class FakeLink:
    """A robot that publishes a new state at every read, the ``bad``-th one replaced."""

    def __init__(self, bad: int | None = None, bad_wire: bytes = b"") -> None:
        self.sent: list[bytes] = []
        self.reads, self.bad, self.bad_wire = 0, bad, bad_wire

    def wire(self) -> bytes:
        return encode_low_state(self.reads, np.array([1.0, 0, 0, 0]), np.zeros(3),
                                constants.DEFAULT_JOINT_POS, np.zeros(N), np.zeros(N))

    def latest(self) -> RawSample:
        self.reads += 1
        wire = self.bad_wire if self.reads == self.bad else self.wire()
        return RawSample(wire=wire, t_receive=time.monotonic(), count=self.reads)

    def wait_for(self, timeout_s: float) -> RawSample:
        return self.latest()

    def write(self, wire: bytes) -> None:
        self.sent.append(wire)

    def other_writers(self) -> list[str]:
        return []  # the only controller on the domain

    def other_writes(self) -> list[str]:
        return []

    @property
    def count(self) -> int:
        return self.reads


@pytest.fixture(scope="module")
def policy(tmp_path_factory):
    return write_stand_in_policy(tmp_path_factory.mktemp("zero"), "zero")


def _run(monkeypatch, policy, link: FakeLink) -> None:
    monkeypatch.setattr(bridge, "FastLink", lambda *args: link)
    safety = SafetyConfig(SafetyLimits.from_robot(), skip_startup=True, overrun_s=1.0)
    run_controller(f"onnx:{policy}", seconds=1.0, safety=safety, damping_s=0.1)


def _check_damped_after_stiff(link: FakeLink, damping_kd: np.ndarray) -> None:
    commands = [decode_low_cmd(w)[0] for w in link.sent]
    stiff = [k for k, c in enumerate(commands) if (c.kp > 0).any()]
    assert stiff, "the policy never ran"
    after = commands[stiff[-1] + 1:]
    assert len(after) == 5  # damping_s / period
    for cmd in after:
        assert (cmd.kp == 0).all()
        np.testing.assert_allclose(cmd.kd, damping_kd, rtol=1e-6)
    assert all(decode_low_cmd(w)[2] for w in link.sent)  # valid CRCs


def test_a_malformed_state_sends_damping_then_names_the_cause(monkeypatch, policy):
    link = FakeLink(bad=5, bad_wire=b"\x00\x01\x00\x00" + bytes(100))
    with pytest.raises(ControllerError) as info:
        _run(monkeypatch, policy, link)
    message = str(info.value)
    assert message.startswith("the control loop failed ")
    assert "(ValueError: LowState_ " in message and message.endswith("; 5 damping commands sent")
    assert isinstance(info.value.__cause__, ValueError)
    _check_damped_after_stiff(link, constants.KD)


def test_an_inference_error_sends_damping_then_names_the_cause(monkeypatch, policy):
    from hybrid_recovery.deploy import policy_runner

    calls = []
    real_step = policy_runner.policy_step

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) == 5:
            raise RuntimeError("onnxruntime: bad allocation")
        return real_step(*args, **kwargs)

    monkeypatch.setattr(policy_runner, "policy_step", failing)
    link = FakeLink()
    with pytest.raises(ControllerError) as info:
        _run(monkeypatch, policy, link)
    assert "(RuntimeError: onnxruntime: bad allocation); 5 damping commands sent" in str(
        info.value)
    _check_damped_after_stiff(link, constants.KD)


def test_run_robot_exits_1_with_one_error_line(monkeypatch, capsys, policy):
    from hybrid_recovery.cli.main import main

    def failing(*args, **kwargs):
        raise ControllerError("the control loop failed 0.10 s after the first state "
                              "(ValueError: x); 25 damping commands sent")

    monkeypatch.setattr(bridge, "run_controller", failing)
    assert main(["run-robot", "--policy", str(policy)]) == 1
    captured = capsys.readouterr()
    assert captured.err == ("error: the control loop failed 0.10 s after the first state "
                            "(ValueError: x); 25 damping commands sent\n")
    assert captured.out == ""


def _state(tick: int, t: float, quat=(1.0, 0.0, 0.0, 0.0)) -> LowStateReading:
    return LowStateReading(tick=tick, quat=np.array(quat), gyro=np.zeros(3),
                      q=constants.DEFAULT_JOINT_POS.copy(), dq=np.zeros(N), tau_est=np.zeros(N),
                      t_receive=t)


def test_a_non_unit_imu_quaternion_is_a_fault():
    sm = SafetyStateMachine(SafetyConfig(SafetyLimits.from_robot()))
    sm.tick(0.0, _state(1, 0.0))
    sm.tick(0.02, _state(2, 0.02, quat=(0.7071, 0.0, 0.7071, 0.0)))  # unit to 1e-4: fine
    assert sm.phase is Phase.ZERO_TORQUE
    cmd = sm.tick(0.04, _state(3, 0.04, quat=(2.0, 0.0, 0.0, 0.0)))
    assert sm.phase is Phase.DAMPING and sm.fault is Fault.IMU_QUATERNION
    assert sm.fault_detail == "IMU quaternion norm 2.000 at tick 3, expected 1 ± 0.01"
    assert cmd is not None and (cmd.kp == 0).all()


def test_older_ticks_are_ignored_modulo_two_to_the_32():
    assert tick_is_newer(11, 10) and not tick_is_newer(10, 10) and not tick_is_newer(9, 10)
    assert tick_is_newer(3, 2**32 - 5) and not tick_is_newer(2**32 - 5, 3)
    sm = SafetyStateMachine(SafetyConfig(SafetyLimits.from_robot()))
    sm.tick(0.0, _state(2**32 - 5, 0.0))
    sm.tick(0.02, _state(100, 0.02))  # the counter wrapped: newer
    assert sm.state is not None and sm.state.tick == 100
    sm.tick(0.04, _state(90, 0.04))  # an older state arriving late: ignored
    assert sm.state.tick == 100 and sm.state.t_receive == 0.02
    for k in range(3, 8):  # only old ticks from now on: the state goes stale
        sm.tick(0.02 * k, _state(90 - k, 0.02 * k))
    assert sm.fault is Fault.STALE_STATE
