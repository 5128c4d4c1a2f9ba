"""The robot runner of a registered controller: the state it estimates from ``LowState_``
and the commands it sends."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.controllers import make
from hybrid_recovery.deploy.controller_runner import ControllerRunner
from hybrid_recovery.deploy.robot_io import JointCommand
from hybrid_recovery.deploy.sim2sim import start_state
from hybrid_recovery.deploy.sim_robot import SimRobot
from hybrid_recovery.deploy.state_machine import Phase
from hybrid_recovery.policy import is_shipped
from hybrid_recovery.robot import constants


@pytest.fixture(scope="module")
def runner() -> ControllerRunner:
    return ControllerRunner(make("qp", prefer="torque"))


@pytest.fixture
def robot() -> SimRobot:
    return SimRobot(None, *start_state(None, "standing", 0.001))


def test_the_estimate_is_the_simulation_where_the_lower_sole_stands_still(runner, robot):
    """Orientation, joints and angular velocity from the IMU and encoders exactly; the
    height from the lowest collision point within 2 mm of a settled stance; the base
    velocity exactly when the lower sole does not move."""
    estimate = runner.estimate
    estimate.reset()
    d = estimate.update(robot.state())
    truth = robot.data
    assert np.allclose(d.qpos[3:], truth.qpos[3:], atol=1e-9)
    assert abs(d.qpos[2] - truth.qpos[2]) < 2e-3
    rng = np.random.default_rng(0)
    truth.qvel[3:] = rng.normal(0.0, 0.5, robot.model.nv - 3)
    truth.qvel[:3] = 0.0
    mujoco.mj_forward(robot.model, truth)
    jacp = np.zeros((3, robot.model.nv))
    foot = robot.model.site(("left_foot", "right_foot")[estimate.stance]).id
    mujoco.mj_jacSite(robot.model, truth, jacp, None, foot)
    truth.qvel[:3] = -(jacp @ truth.qvel)  # the stance sole at rest
    d = estimate.update(robot.state())
    assert np.allclose(d.qvel, truth.qvel, atol=1e-9)


def test_a_torque_step_goes_out_as_feed_forward_torque_with_kp_zero(runner, robot):
    runner.reset()
    state = robot.state()
    out = runner.step(state)
    assert runner.output == "torque" and runner.period_s == 0.002
    assert np.array_equal(out.q_ref, state.q) and out.action.shape == (constants.NUM_JOINTS,)
    runner._torque = 10.0 * constants.EFFORT_LIMITS  # beyond every limit
    stiff = JointCommand(q=state.q, kp=constants.KP.copy(), kd=constants.KD.copy())
    sent = runner.command(stiff, Phase.POLICY)
    assert np.all(sent.kp == 0) and np.all(sent.kd == 0)
    assert np.array_equal(sent.tau, constants.EFFORT_LIMITS)
    assert np.array_equal(sent.q, state.q)
    assert runner.command(stiff, Phase.POLICY) is stiff  # no step this tick: the machine's
    runner.step(state)
    damping = JointCommand(q=state.q, kd=constants.KD.copy())
    assert runner.command(damping, Phase.DAMPING) is damping


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_the_hybrid_sends_the_policys_targets_while_its_torque_is_their_pd_law(robot):
    """The hybrid starts with the policy: τ is the PD law on the policy's targets, so the
    step hands the machine those targets (sent with its gains), not the torque."""
    runner = ControllerRunner(make("hybrid", prefer="torque"))
    state = robot.state()
    out = runner.step(state)
    target = runner.controller.joint_target
    assert runner.output == "torque" and target is not None
    assert np.array_equal(out.q_ref, target)
    assert np.allclose(out.action, pd_torque(target, state.q, state.dq))
    stiff = JointCommand(q=target, kp=constants.KP.copy(), kd=constants.KD.copy())
    assert runner.command(stiff, Phase.POLICY) is stiff
