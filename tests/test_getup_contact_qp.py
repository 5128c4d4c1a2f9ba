"""The multi-contact torque QP: Newton–Euler against Pinocchio, limits, fallbacks, messages."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.control.wbc_qp import Task
from hybrid_recovery.dynamics.conventions import qacc_to_pin, qpos_to_pin, qvel_to_pin
from hybrid_recovery.dynamics.robot_model import GRAVITY
from hybrid_recovery.evaluation.handover_map import handover_start
from hybrid_recovery.getup.contact_ik import CONTACT_KEYFRAMES, ContactIk
from hybrid_recovery.getup.contact_qp import ContactQP, ContactQpConfig
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS
from hybrid_recovery.getup.push_up import HANDS_KNEES_TOES, PushUp, PushUpConfig, on_hands_and_knees
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import load_mjmodel

ALL_CONTACTS = HANDS_KNEES_TOES


@pytest.fixture(scope="module")
def model():
    return load_torque_model()


@pytest.fixture(scope="module")
def hands_knees(model):
    """The hands-and-knees IK keyframe: every contact of the set on the floor, at rest."""
    ik = ContactIk(load_mjmodel(floor=False, actuators=False))
    return ik.solve(CONTACT_KEYFRAMES["hands_knees"]).qpos


def _hold(qp: ContactQP, weight: float = 1.0) -> list[Task]:
    """Ask for q̈_a = 0 (hold the posture)."""
    return [Task("posture", np.hstack([np.zeros((27, 6)), np.eye(27)]), np.zeros(27), weight)]


def _data(model, qpos, qvel=None):
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    if qvel is not None:
        data.qvel[:] = qvel
    mujoco.mj_forward(model, data)
    return data


def test_static_keyframe_forces_balance_weight_and_torques_in_limits(model, hands_knees):
    qp = ContactQP(model)
    state = qp.read(_data(model, hands_knees))
    sol = qp.solve(state, ALL_CONTACTS, _hold(qp))
    assert sol.status == "solved"
    assert set(sol.points.names) == set(ALL_CONTACTS)
    # Newton: Σ f = m (c̈ + g ẑ), c̈ = J_c q̈ at q̇ = 0; at rest q̈ ≈ 0 so Σ f ≈ m g ẑ
    jac_com = np.zeros((3, model.nv))
    mujoco.mj_jacSubtreeCom(model, qp.reader.data, jac_com, 1)
    mass = qp.reader.mass
    expected = mass * (jac_com @ sol.qacc + np.array([0.0, 0.0, GRAVITY]))
    np.testing.assert_allclose(sol.forces.sum(axis=0), expected, atol=1e-6 * mass * GRAVITY)
    np.testing.assert_allclose(sol.forces.sum(axis=0), [0.0, 0.0, mass * GRAVITY],
                               atol=0.01 * mass * GRAVITY)
    # forces in the friction pyramid (inner: |f_x| + |f_y| ≤ μ f_z √2 bounds each edge)
    mu = qp.cfg.friction
    assert np.all(sol.forces[:, 2] >= -1e-9)
    assert np.all(np.abs(sol.forces[:, :2]) <= mu * sol.forces[:, 2:3] + 1e-6)
    assert np.all(np.abs(sol.torque) <= constants.EFFORT_LIMITS + 1e-9)


@pytest.mark.parametrize("seed", [0, 1])
def test_torques_reproduce_pinocchio_inverse_dynamics(model, hands_knees, seed):
    """τ = M q̈ + h − Σ J_iᵀ f_i on the joint rows and M_u q̈ + h_u = Σ J_u,iᵀ f_i on the
    base rows, with M q̈ + h from Pinocchio's RNEA (with the rotor armature) in its own
    coordinates: an independent check of MuJoCo's M, h and of the contact Jacobians."""
    rng = np.random.default_rng(seed)
    qvel = rng.normal(scale=0.2, size=model.nv)
    data = _data(model, hands_knees, qvel)
    qp = ContactQP(model, ContactQpConfig(effort_scale=3.0))
    state = qp.read(data)
    sol = qp.solve(state, ALL_CONTACTS, _hold(qp))
    assert sol.status == "solved"
    robot = qp.reader.robot
    pm, pd = robot.model, robot.data
    q = qpos_to_pin(hands_knees)
    v = qvel_to_pin(hands_knees, qvel)
    a = qacc_to_pin(hands_knees, qvel, sol.qacc)
    tau_id = pin.rnea(pm, pd, q, v, a).copy()
    pin.computeJointJacobians(pm, pd, q)
    pin.updateFramePlacements(pm, pd)
    contact_force = np.zeros(model.nv)
    for name, p, f in zip(sol.points.names, sol.points.positions, sol.forces, strict=True):
        frame = pm.getFrameId(FLOOR_CONTACTS[name].body, pin.FrameType.BODY)
        jac = pin.getFrameJacobian(pm, pd, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        r = p - pd.oMf[frame].translation
        skew = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        contact_force += (jac[:3] - skew @ jac[3:]).T @ f
    scale = 1e-6 * max(1.0, float(np.abs(tau_id).max()))
    np.testing.assert_allclose(sol.torque, tau_id[6:] - contact_force[6:], atol=scale)
    np.testing.assert_allclose(tau_id[:6], contact_force[:6], atol=scale)


def test_infeasible_request_is_relaxed_and_finite(model, hands_knees):
    # at 1 % of the effort limits no contact forces hold the robot: the torque rows go
    qp = ContactQP(model, ContactQpConfig(effort_scale=0.01))
    sol = qp.solve(qp.read(_data(model, hands_knees)), ALL_CONTACTS, _hold(qp))
    assert sol.status == "relaxed"
    assert qp.solver_report.startswith("solved: PROXQP_PRIMAL_INFEASIBLE")
    assert "limits_relaxed: PROXQP_PRIMAL_INFEASIBLE" in qp.solver_report
    assert np.isfinite(sol.torque).all()
    assert np.all(np.abs(sol.torque) <= constants.EFFORT_LIMITS)


def test_nan_state_falls_back_to_damping_then_last_good(model, hands_knees):
    qp = ContactQP(model)
    bad = _data(model, hands_knees)
    bad.qvel[7] = np.nan
    first = qp.solve(qp.read(bad), ALL_CONTACTS, _hold(qp))
    assert first.status == "damping"
    assert np.isfinite(first.torque).all()
    good = qp.solve(qp.read(_data(model, hands_knees)), ALL_CONTACTS, _hold(qp))
    assert good.status == "solved"
    again = qp.solve(qp.read(bad), ALL_CONTACTS, _hold(qp))
    assert again.status == "last_good"
    np.testing.assert_array_equal(again.torque, good.torque)


def test_messages(model, hands_knees):
    qp = ContactQP(model)
    state = qp.read(_data(model, hands_knees))
    with pytest.raises(ValueError, match="^unknown contact 'left_paw': use one of"):
        qp.solve(state, ("left_paw",), _hold(qp))
    with pytest.raises(ValueError, match=r"^reference_forces must have shape \(8, 3\), "
                                         r"got \(2, 3\)$"):
        qp.solve(state, ALL_CONTACTS, _hold(qp), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="^ContactQpConfig.friction must be > 0, got 0.0$"):
        ContactQpConfig(friction=0.0)
    with pytest.raises(ValueError, match="^unknown keyframe 'squat': use one of"):
        PushUpConfig(keyframe="squat")


def test_push_up_from_knee_chest_ends_on_hands_and_knees(model):
    """The torque-level push-up (2 ms, ctrl = τ) from a noisy settled knee-chest."""
    data = handover_start(model, "knee_chest", np.random.default_rng(2))
    mujoco.mj_forward(model, data)
    assert not on_hands_and_knees(model, data)[0]  # the criterion is not met at the start
    controller = PushUp()
    controller.reset(model, data)
    cfg = controller.config
    for _ in range(int(round((cfg.duration + 1.0) / model.opt.timestep))):
        tau = controller(model, data)
        assert np.isfinite(tau).all() and np.all(np.abs(tau) <= constants.EFFORT_LIMITS)
        data.ctrl[:] = tau
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    arrived, what = on_hands_and_knees(model, data)
    assert arrived, what
