"""The deployment safety state machine: the start-up sequence, every fault, damping on exit.

Pure logic on synthetic states: no simulator, no DDS, no clock.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.deploy.robot_io import LowStateReading
from hybrid_recovery.deploy.state_machine import (
    Fault,
    Phase,
    PolicyOutput,
    SafetyConfig,
    SafetyStateMachine,
)
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits

N = constants.NUM_JOINTS
DT = 0.02
LIMITS = SafetyLimits(q_min=np.full(N, -1.0), q_max=np.full(N, 1.0))


def _state(tick: int, t: float, q: np.ndarray | None = None, **kw) -> LowStateReading:
    fields = dict(quat=np.array([1.0, 0, 0, 0]), gyro=np.zeros(3),
                  q=np.zeros(N) if q is None else q, dq=np.zeros(N), tau_est=np.zeros(N))
    fields.update(kw)
    return LowStateReading(tick=tick, t_receive=t, **fields)


def _policy(q_ref: np.ndarray | None = None, obs_nan: bool = False,
            action_nan: bool = False) -> PolicyOutput:
    obs = np.zeros(87)
    action = np.zeros(N)
    if obs_nan:
        obs[5] = np.nan
    if action_nan:
        action[3] = np.inf
    return PolicyOutput(obs=obs, action=action,
                        q_ref=constants.DEFAULT_JOINT_POS if q_ref is None else q_ref)


class Driver:
    """Ticks a machine every 20 ms with a fresh state (tick += 10 per tick)."""

    def __init__(self, **config) -> None:
        self.sm = SafetyStateMachine(SafetyConfig(LIMITS, **config))
        self.t, self.tick = 0.0, 0

    def step(self, n: int = 1, policy: PolicyOutput | None = None, **state_kw):
        cmd = None
        for _ in range(n):
            self.t += DT
            self.tick += 10
            pol = policy if self.sm.phase is Phase.POLICY else None
            cmd = self.sm.tick(self.t, _state(self.tick, self.t, **state_kw), pol)
        return cmd

    def to_policy(self) -> None:
        self.step(int((0.5 + 2.0 + 1.0) / DT) + 2)
        assert self.sm.phase is Phase.POLICY


def test_nothing_is_sent_before_the_first_state():
    sm = SafetyStateMachine(SafetyConfig(LIMITS))
    for k in range(10):
        assert sm.tick(k * DT, None) is None
    assert sm.phase is Phase.WAIT_STATE and sm.fault is None


def test_startup_sequence_zero_torque_interpolate_hold_policy():
    d = Driver()
    q0 = np.full(N, 0.5)
    cmd = d.step(q=q0)
    assert d.sm.phase is Phase.ZERO_TORQUE
    assert not cmd.kp.any() and not cmd.kd.any() and not cmd.tau.any()
    cmd = d.step(round(0.5 / DT) - 1, q=q0)
    assert d.sm.phase is Phase.ZERO_TORQUE
    cmd = d.step(q=q0)
    assert d.sm.phase is Phase.INTERPOLATE  # entered 0.5 s later, q₀ measured then
    np.testing.assert_allclose(cmd.q, q0)
    np.testing.assert_allclose(cmd.kp, constants.KP)
    np.testing.assert_allclose(cmd.kd, constants.KD)
    cmd = d.step(round(1.0 / DT), q=q0)  # half way through the 2 s
    np.testing.assert_allclose(cmd.q, q0 + 0.5 * (constants.DEFAULT_JOINT_POS - q0), atol=1e-6)
    cmd = d.step(round(1.0 / DT))
    assert d.sm.phase is Phase.HOLD
    np.testing.assert_allclose(cmd.q, constants.DEFAULT_JOINT_POS)
    d.step(round(1.0 / DT) - 1)
    assert d.sm.phase is Phase.HOLD
    d.step(1)
    assert d.sm.phase is Phase.POLICY
    target = constants.DEFAULT_JOINT_POS + 0.1
    cmd = d.step(policy=_policy(target))
    np.testing.assert_allclose(cmd.q, target)
    assert [p for _, p, _ in d.sm.transitions] == [
        Phase.ZERO_TORQUE, Phase.INTERPOLATE, Phase.HOLD, Phase.POLICY]


def test_hold_waits_for_start_without_auto_start():
    d = Driver(auto_start_policy=False)
    d.step(200)
    assert d.sm.phase is Phase.HOLD
    d.sm.start_policy()
    d.step(1)
    assert d.sm.phase is Phase.POLICY


@pytest.mark.parametrize("phase_ticks", [1, 30, 100, 200])
def test_stop_request_damps_in_every_phase_and_stays(phase_ticks):
    d = Driver()
    d.step(phase_ticks)
    d.sm.request_stop()
    cmd = d.step()
    assert d.sm.phase is Phase.DAMPING and d.sm.fault is None
    assert d.sm.fault_detail == "stop requested"
    assert not cmd.kp.any()
    np.testing.assert_allclose(cmd.kd, constants.KD)
    d.sm.start_policy()
    for _ in range(5):
        assert not d.step(policy=_policy()).kp.any()
    assert d.sm.phase is Phase.DAMPING


def test_nonfinite_observation_and_action_are_faults():
    for kw, fault, detail in (
        ({"obs_nan": True}, Fault.NONFINITE_OBSERVATION, "observation has NaN or inf"),
        ({"action_nan": True}, Fault.NONFINITE_ACTION, "action has NaN or inf"),
        ({"q_ref": np.full(N, np.nan)}, Fault.NONFINITE_ACTION, "action has NaN or inf"),
    ):
        d = Driver()
        d.to_policy()
        cmd = d.step(policy=_policy(**kw))
        assert (d.sm.phase, d.sm.fault, d.sm.fault_detail) == (Phase.DAMPING, fault, detail)
        assert not cmd.kp.any() and np.isfinite(cmd.q).all()


def test_nonfinite_state_is_a_fault():
    d = Driver()
    d.step(3)
    q = np.zeros(N)
    q[7] = np.nan
    d.step(q=q)
    assert d.sm.fault is Fault.NONFINITE_STATE
    assert d.sm.fault_detail == f"state at tick {d.tick} has NaN or inf"


def test_joint_limit_violation_is_a_fault_with_the_joint_named():
    d = Driver()
    d.to_policy()
    q = np.zeros(N)
    q[3] = 1.0 + 0.1 + 1e-3  # beyond range + margin
    d.step(q=q, policy=_policy())
    assert d.sm.fault is Fault.JOINT_LIMIT
    assert d.sm.fault_detail == ("left_knee_joint at 1.101 rad outside [-1.000, 1.000] "
                                 "± 0.1 rad")
    d2 = Driver()
    q[3] = 1.09  # inside the margin: no fault
    d2.step(5, q=q)
    assert d2.sm.fault is None


def test_torque_limit_violation_is_a_fault():
    d = Driver()
    d.step(50)
    tau = np.zeros(N)
    tau[4] = -constants.EFFORT_LIMITS[4] * 1.2
    d.step(tau_est=tau)
    assert d.sm.fault is Fault.TORQUE_LIMIT
    assert d.sm.fault_detail == "left_ankle_pitch_joint torque -72.0 N·m beyond 60 N·m (+10 %)"


def test_stale_state_is_a_fault():
    d = Driver()
    d.step(10)
    last = _state(d.tick, d.t)
    t = d.t
    for _ in range(5):  # the same tick again and again: no new state for 100 ms
        t += DT
        d.sm.tick(t, last)
    assert d.sm.phase is not Phase.DAMPING
    t += DT
    d.sm.tick(t, last)
    assert d.sm.fault is Fault.STALE_STATE
    assert d.sm.fault_detail == f"no new state for 120 ms (last tick {d.tick})"


def test_states_with_a_bad_crc_are_ignored_and_go_stale():
    d = Driver()
    d.step(10)
    t, tick = d.t, d.tick
    for _ in range(6):
        t += DT
        tick += 10
        d.sm.tick(t, LowStateReading(tick=tick, quat=np.array([1.0, 0, 0, 0]), gyro=np.zeros(3),
                                     q=np.zeros(N), dq=np.zeros(N), tau_est=np.zeros(N),
                                     t_receive=t, crc_ok=False))
    assert d.sm.fault is Fault.STALE_STATE
    assert d.sm.state.tick == d.tick


def test_overrun_is_a_fault():
    d = Driver()
    d.step(10)
    d.t += 0.045  # a tick 65 ms after the previous one (period 20 + allowance 20 ms)
    cmd = d.step()
    assert d.sm.fault is Fault.OVERRUN
    assert d.sm.fault_detail == "tick 65.0 ms after the previous one (period 20 ms)"
    assert not cmd.kp.any()


def test_gains_and_targets_are_clamped():
    d = Driver(kp=constants.KP * 3, kd=constants.KD * 3, damping_kd=constants.KD * 5)
    d.to_policy()
    cmd = d.step(policy=_policy(np.full(N, 5.0)))
    np.testing.assert_allclose(cmd.kp, constants.KP)
    np.testing.assert_allclose(cmd.kd, constants.KD)
    np.testing.assert_allclose(cmd.q, 0.9)  # range [-1, 1] scaled by q_ref_range_factor 0.9
    d.sm.request_stop()
    np.testing.assert_allclose(d.step().kd, constants.KD)


def test_skip_startup_goes_straight_to_policy():
    d = Driver(skip_startup=True)
    d.step()
    assert d.sm.phase is Phase.POLICY
    cmd = d.step(policy=_policy())
    np.testing.assert_allclose(cmd.q, constants.DEFAULT_JOINT_POS)


def test_robot_limits_come_from_the_mjcf_and_constants():
    lim = SafetyLimits.from_robot()
    knee = constants.JOINT_NAMES.index("left_knee_joint")
    assert (lim.q_min[knee], lim.q_max[knee]) == pytest.approx((-0.12, 2.19))
    assert np.all(lim.q_min < constants.DEFAULT_JOINT_POS)
    assert np.all(constants.DEFAULT_JOINT_POS < lim.q_max)
    lo, hi = lim.q_ref_bounds(0.9)
    assert np.all((lo < constants.DEFAULT_JOINT_POS) & (constants.DEFAULT_JOINT_POS < hi))
