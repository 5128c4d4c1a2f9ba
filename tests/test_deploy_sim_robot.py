"""The simulated robot (motor-driver PD, CRC checks, reported state), the start-up sequence
in-process, and a short sim-to-sim run with its balance trace."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from hybrid_recovery.deploy.balance_trace import COLUMNS
from hybrid_recovery.deploy.policy_runner import PolicyRunner
from hybrid_recovery.deploy.robot_io import JointCommand
from hybrid_recovery.deploy.sim2sim import Sim2SimConfig, run_sim2sim
from hybrid_recovery.deploy.sim_robot import SimRobot, SimRobotConfig
from hybrid_recovery.deploy.state_machine import Phase, SafetyConfig, SafetyStateMachine
from hybrid_recovery.deploy.wire import decode_low_state, encode_low_cmd
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.training.stand_in import write_stand_in_policy

N = constants.NUM_JOINTS


@pytest.fixture(scope="module")
def zero_policy(tmp_path_factory):
    return write_stand_in_policy(tmp_path_factory.mktemp("zero"), "zero")


def test_driver_pd_law_and_effort_clip():
    robot = SimRobot()
    rng = np.random.default_rng(0)
    cmd = JointCommand(q=constants.DEFAULT_JOINT_POS + rng.uniform(-0.3, 0.3, N),
                       kp=constants.KP * 0.5, kd=constants.KD, dq=rng.normal(size=N),
                       tau=rng.normal(size=N))
    robot.apply_command(cmd)
    robot.step(3)
    s = robot.state()
    expected = np.clip(cmd.torque(s.q, s.dq), -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
    np.testing.assert_allclose(s.tau_est, expected, rtol=1e-9, atol=1e-9)
    assert np.abs(s.tau_est).max() > 10.0


def test_bad_crc_commands_are_rejected_and_the_previous_one_kept():
    robot = SimRobot()
    good = JointCommand(q=constants.DEFAULT_JOINT_POS, kp=constants.KP, kd=constants.KD)
    assert robot.apply_command_wire(encode_low_cmd(good))
    bad = bytearray(encode_low_cmd(JointCommand(kp=np.full(N, 999.0))))
    bad[-1] ^= 0xFF
    assert not robot.apply_command_wire(bytes(bad))
    assert (robot.accepted, robot.rejected) == (1, 1)
    f32 = lambda x: np.asarray(x, np.float32)  # noqa: E731  (the wire carries float32)
    np.testing.assert_array_equal(f32(robot.model.actuator_gainprm[:, 0]), f32(constants.KP))
    np.testing.assert_array_equal(f32(robot.data.ctrl), f32(constants.DEFAULT_JOINT_POS))


def test_published_state_has_increasing_ticks_valid_crc_and_the_torso_imu():
    robot = SimRobot()
    ticks = []
    for _ in range(3):
        robot.step(2)
        s = decode_low_state(robot.state_wire())
        assert s.crc_ok and s.mode_machine == robot.cfg.mode_machine
        ticks.append(s.tick)
    assert ticks == [2, 4, 6]
    d = robot.data
    site = robot.model.site("imu").id
    assert robot.model.site_bodyid[site] == robot.torso
    quat = np.zeros(4)
    import mujoco

    mujoco.mju_mat2Quat(quat, d.site_xmat[site])
    np.testing.assert_allclose(s.quat, quat * np.sign(quat[0]), atol=1e-6)
    np.testing.assert_allclose(s.q, d.qpos[robot.qadr], atol=1e-6)


def test_startup_sequence_on_the_gantry_then_standing(zero_policy):
    robot = SimRobot(SimRobotConfig(gantry_s=3.0))
    sm = SafetyStateMachine(SafetyConfig(SafetyLimits.from_robot()))
    runner = PolicyRunner(zero_policy)
    heights = {}
    while robot.time < 6.0:
        state = robot.state()
        policy = runner.step(state) if sm.phase is Phase.POLICY else None
        cmd = sm.tick(robot.time, state, policy)
        if cmd is not None:
            robot.apply_command(cmd)
        robot.step(20)
        heights[sm.phase] = robot.base_height()
    assert sm.fault is None and sm.phase is Phase.POLICY
    assert not robot.gantry_on
    assert robot.base_height() > 0.98 and robot.torso_tilt_deg() < 8.0
    np.testing.assert_allclose(robot.data.qpos[robot.qadr], constants.DEFAULT_JOINT_POS,
                               atol=0.1)


def test_sim2sim_writes_a_consistent_balance_trace(zero_policy, tmp_path):
    cfg = Sim2SimConfig(pose="standing", seconds=1.0, push_force=100.0, push_time=0.5,
                        push_duration=0.1, video=False)
    summary = run_sim2sim(f"onnx:{zero_policy}", tmp_path, cfg)
    assert summary["fault"] is None and summary["final_phase"] == "policy"
    assert json.loads((tmp_path / "summary.json").read_text())["fault"] is None
    assert (tmp_path / "trace.png").stat().st_size > 10_000
    with (tmp_path / "trace.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == COLUMNS and len(rows) == 50
    first = {k: float(v) for k, v in rows[0].items() if k != "phase"}
    # a settled, standing robot: ξ ≈ CoM ground projection, CoM near 0.92 m, upright torso
    assert abs(first["cp_x"] - first["com_x"]) < 0.01 and abs(first["cp_y"] - first["com_y"]) < 0.01
    assert 0.88 < first["com_z"] < 0.95 and first["tilt_deg"] < 8.0
    pushed = [float(r["push"]) for r in rows]
    assert max(pushed) == pytest.approx(100.0) and pushed[0] == 0.0
    cp_x = np.array([float(r["cp_x"]) for r in rows])
    com_x = np.array([float(r["com_x"]) for r in rows])
    # impulse J = 10 N·s along +x: ξ − c = ċ/ω ≈ J / (m ω) ≈ 0.046 m, less what the feet resist
    omega = np.sqrt(9.81 / first["com_z"])
    expected = 100.0 * 0.1 / (constants.TOTAL_MASS * omega)
    assert 0.6 * expected < (cp_x - com_x).max() < 1.1 * expected
