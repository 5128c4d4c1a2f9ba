"""The dynamics layer against MuJoCo's own quantities, finite differences and analytic cases."""

from __future__ import annotations

import copy

import mujoco
import numpy as np
import pytest
from conftest import random_state

from hybrid_recovery.dynamics import GRAVITY, RobotModel


def _mujoco_momentum(model, qpos, qvel):
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    mujoco.mj_forward(model, data)
    mujoco.mj_subtreeVel(model, data)
    mass = model.body_subtreemass[1]
    return (data.subtree_com[1].copy(), data.subtree_linvel[1].copy(),
            mass * data.subtree_linvel[1], data.subtree_angmom[1].copy())


def test_total_mass(robot):
    assert robot.mass == pytest.approx(66.984, abs=1e-6)


def test_com_and_momentum_equal_mujoco(robot):
    rng = np.random.default_rng(0)
    for _ in range(50):
        qpos, qvel = random_state(robot.mj_model, rng)
        com, com_vel, lin, ang = _mujoco_momentum(robot.mj_model, qpos, qvel)
        state = robot.balance_state(qpos, qvel)
        for got, ref in ((state.com, com), (state.com_vel, com_vel),
                         (state.linear_momentum, lin), (state.angular_momentum, ang)):
            np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-6 * np.abs(ref).max())


def test_batched_equals_single(robot):
    rng = np.random.default_rng(1)
    states = [random_state(robot.mj_model, rng) for _ in range(5)]
    qpos, qvel = np.array([s[0] for s in states]), np.array([s[1] for s in states])
    batch = robot.balance_state(qpos, qvel)
    assert batch.com.shape == (5, 3) and batch.capture_point.shape == (5, 2)
    for i in range(5):
        single = robot.balance_state(qpos[i], qvel[i])
        np.testing.assert_allclose(batch.angular_momentum[i], single.angular_momentum)
        np.testing.assert_allclose(batch.capture_point[i], single.capture_point)


def test_cmm_times_qvel_is_momentum(robot):
    rng = np.random.default_rng(2)
    for _ in range(20):
        qpos, qvel = random_state(robot.mj_model, rng)
        state = robot.balance_state(qpos, qvel)
        a_mat = robot.centroidal_momentum_matrix(qpos)
        assert a_mat.shape == (6, robot.nv)
        expected = np.r_[state.linear_momentum, state.angular_momentum]
        np.testing.assert_allclose(a_mat @ qvel, expected, rtol=1e-9, atol=1e-9)


def _trajectory(robot, steps=400, dt=1e-3):
    """A passive, falling, tumbling trajectory simulated by MuJoCo (floor removed)."""
    model = copy.copy(robot.mj_model)
    model.opt.timestep = dt
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    data.qpos[:], data.qvel[:] = random_state(model, rng)
    data.qpos[2] = 5.0
    data.qvel[:] *= 0.5
    out = []
    for _ in range(steps):
        mujoco.mj_forward(model, data)
        out.append((data.qpos.copy(), data.qvel.copy(), data.qacc.copy()))
        mujoco.mj_step(model, data)
    return out


def test_com_acceleration_and_cmm_drift_match_finite_differences(own_model):
    robot = own_model
    dt = 1e-3
    traj = _trajectory(robot, dt=dt)
    for k in (50, 150, 300):
        qpos, qvel, qacc = traj[k]
        state = robot.balance_state(qpos, qvel, qacc)
        prev = robot.balance_state(*traj[k - 1][:2])
        nxt = robot.balance_state(*traj[k + 1][:2])
        fd_acc = (nxt.com_vel - prev.com_vel) / (2 * dt)
        np.testing.assert_allclose(state.com_acc, fd_acc, atol=5e-3 * max(1, np.abs(fd_acc).max()))
        # dh/dt = A qacc + Ȧ qvel, compared with finite differences of h along the trajectory
        h_dot = robot.centroidal_momentum_matrix(qpos) @ qacc + robot.centroidal_momentum_drift(
            qpos, qvel)
        h = lambda s: np.r_[s.linear_momentum, s.angular_momentum]  # noqa: E731
        fd_h = (h(nxt) - h(prev)) / (2 * dt)
        np.testing.assert_allclose(h_dot, fd_h, atol=2e-2 * max(1, np.abs(fd_h).max()))


def test_free_fall_com_acceleration_is_gravity(own_model):
    """With no contact, the only external force is gravity: p̈_c = (0, 0, −g)."""
    traj = _trajectory(own_model, steps=60)
    qpos, qvel, qacc = traj[-1]
    acc = own_model.balance_state(qpos, qvel, qacc).com_acc
    np.testing.assert_allclose(acc, own_model.mj_model.opt.gravity, atol=1e-6)


def test_capture_point_at_rest_is_com_projection(own_model):
    rng = np.random.default_rng(4)
    qpos, _ = random_state(own_model.mj_model, rng)
    qpos[2] = 1.0
    state = own_model.balance_state(qpos, np.zeros(own_model.nv))
    np.testing.assert_allclose(state.capture_point, state.com[:2], atol=1e-12)
    assert state.omega == pytest.approx(np.sqrt(GRAVITY / state.com[2]))


def test_rigid_translation_momentum_is_mv(robot):
    rng = np.random.default_rng(5)
    qpos, _ = random_state(robot.mj_model, rng)
    vel = np.array([0.3, -1.2, 0.7])
    qvel = np.zeros(robot.nv)
    qvel[:3] = vel
    state = robot.balance_state(qpos, qvel)
    np.testing.assert_allclose(state.linear_momentum, robot.mass * vel, rtol=1e-12)
    np.testing.assert_allclose(state.angular_momentum, 0.0, atol=1e-12)
    np.testing.assert_allclose(state.com_vel, vel, rtol=1e-12)


def test_capture_point_is_lip_closed_form(own_model):
    qpos = np.zeros(own_model.nq)
    qpos[3] = 1.0
    qpos[2] = 1.0
    qvel = np.zeros(own_model.nv)
    qvel[:2] = [0.4, -0.1]
    state = own_model.balance_state(qpos, qvel)
    omega = np.sqrt(GRAVITY / state.com[2])
    np.testing.assert_allclose(state.capture_point, state.com[:2] + qvel[:2] / omega, rtol=1e-12)


def test_bad_inputs_have_clear_errors(own_model):
    good_q, good_v = np.zeros(own_model.nq), np.zeros(own_model.nv)
    good_q[3] = 1
    with pytest.raises(ValueError, match=r"qpos must have shape \(34,\) or \(N, 34\), got \(33,\)"):
        own_model.balance_state(good_q[:-1], good_v)
    bad = good_v.copy()
    bad[4] = np.nan
    with pytest.raises(ValueError, match=r"qvel contains NaN or inf \(rows \[0\]\)"):
        own_model.balance_state(good_q, bad)
    with pytest.raises(ValueError, match="qvel batch shape"):
        own_model.balance_state(np.stack([good_q] * 2), np.stack([good_v] * 3))


def test_model_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="MJCF file not found: "):
        RobotModel.from_mjcf(tmp_path / "missing.xml")
    fixed = tmp_path / "fixed.xml"
    fixed.write_text('<mujoco><worldbody><body name="a"><joint name="j" type="hinge"/>'
                     '<geom size="0.1"/></body></worldbody></mujoco>')
    with pytest.raises(ValueError, match="model has no free joint"):
        RobotModel.from_mjcf(fixed)
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ValueError, match="cannot parse MJCF"):
        RobotModel.from_mjcf(broken)


def test_unnormalised_base_quaternion_is_read_as_mujoco_reads_it(own_model):
    rng = np.random.default_rng(7)
    qpos, qvel = random_state(own_model.mj_model, rng)
    qpos[3:7] = (0.9, 0.1, 0.0, 0.0)  # norm 0.906: MuJoCo normalises it
    com, com_vel, lin, ang = _mujoco_momentum(own_model.mj_model, qpos, qvel)
    state = own_model.balance_state(qpos, qvel)
    np.testing.assert_allclose(state.com, com, atol=1e-9)
    np.testing.assert_allclose(state.linear_momentum, lin, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(state.angular_momentum, ang, rtol=1e-6, atol=1e-6)
    unit = qpos.copy()
    unit[3:7] /= np.linalg.norm(unit[3:7])
    np.testing.assert_allclose(own_model.centroidal_momentum_matrix(qpos),
                               own_model.centroidal_momentum_matrix(unit), atol=1e-12)
    assert qpos[3] == 0.9  # the caller's array is not changed


def test_zero_base_quaternion_is_refused(own_model):
    qpos = np.zeros((3, own_model.nq))
    qpos[:, 3] = 1.0
    qpos[2, 3:7] = 0.0
    qvel = np.zeros((3, own_model.nv))
    for call in (lambda: own_model.balance_state(qpos, qvel),
                 lambda: own_model.centroidal_momentum_matrix(qpos),
                 lambda: own_model.centroidal_momentum_drift(qpos, qvel)):
        with pytest.raises(ValueError) as info:
            call()
        assert str(info.value) == "qpos base quaternion qpos[3:7] is zero (rows [2])"
