"""The torque model, the tick's state and the whole-body QP: dynamics truths and fallbacks."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control import BalanceController, default_config, load_torque_model
from hybrid_recovery.control.applicability import NAN_STATE_MESSAGE
from hybrid_recovery.control.robot_state import StateReader
from hybrid_recovery.control.rollout import standing_data
from hybrid_recovery.control.torque_model import MODEL_MESSAGE
from hybrid_recovery.control.wbc_qp import Task, WholeBodyQP, pyramid_basis
from hybrid_recovery.dynamics import GRAVITY, RobotModel
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import load_mjmodel


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_torque_model()


def _moving_data(model: mujoco.MjModel, seed: int = 0) -> mujoco.MjData:
    rng = np.random.default_rng(seed)
    data = standing_data(model)
    data.qpos[7:] += rng.uniform(-0.1, 0.1, 27)
    data.qvel[:] = rng.normal(0.0, 0.5, model.nv)
    mujoco.mj_forward(model, data)
    return data


# --- torque model ----------------------------------------------------------------------


def test_torque_model_has_unit_motors_in_motor_order(model):
    assert model.opt.timestep == 0.002
    assert model.nu == constants.NUM_JOINTS
    data = standing_data(model)
    data.ctrl[:] = np.linspace(-1.0, 1.0, 27) * constants.EFFORT_LIMITS * 1.5
    mujoco.mj_forward(model, data)
    expected = np.clip(data.ctrl, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
    np.testing.assert_allclose(data.qfrc_actuator[6:], expected)
    for i, name in enumerate(constants.JOINT_NAMES):
        assert model.joint(model.actuator_trnid[i, 0]).name == name


def test_controller_rejects_position_servos():
    servo_model = load_mjmodel(timestep=0.002)
    with pytest.raises(ValueError) as info:
        BalanceController().reset(servo_model, standing_data(servo_model))
    assert str(info.value) == MODEL_MESSAGE


# --- the tick's state --------------------------------------------------------------------


def test_state_matches_the_dynamics_layer_and_mujoco(model):
    data = _moving_data(model)
    state = StateReader(model).read(data)
    robot = RobotModel(model)
    np.testing.assert_allclose(state.cmm, robot.centroidal_momentum_matrix(data.qpos), atol=1e-9)
    np.testing.assert_allclose(state.cmm_drift,
                               robot.centroidal_momentum_drift(data.qpos, data.qvel), atol=1e-8)
    balance = robot.balance_state(data.qpos, data.qvel)
    np.testing.assert_allclose(state.com, balance.com, atol=1e-10)
    np.testing.assert_allclose(state.com_vel, balance.com_vel, atol=1e-10)
    mass_matrix = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, mass_matrix)
    np.testing.assert_allclose(state.mass_matrix, mass_matrix, atol=1e-12)
    np.testing.assert_allclose(state.bias, data.qfrc_bias, atol=1e-9)


def test_foot_jacobian_derivative_by_finite_differences(model):
    """J̇ q̇ ≈ (J(q + q̇ h) − J(q − q̇ h)) q̇ / 2h for both soles and the pelvis."""
    data = _moving_data(model, seed=3)
    reader = StateReader(model)
    h = 1e-6
    states = []
    for sign in (-1.0, 1.0):
        shifted = mujoco.MjData(model)
        shifted.qpos[:] = data.qpos
        mujoco.mj_integratePos(model, shifted.qpos, data.qvel, sign * h)
        shifted.qvel[:] = data.qvel
        states.append(reader.read(shifted))
    state = reader.read(data)
    for side in (0, 1):
        jdot = (states[1].feet[side].jacobian - states[0].feet[side].jacobian) / (2 * h)
        np.testing.assert_allclose(state.feet[side].bias_acc, jdot @ data.qvel, atol=1e-4)
    jdot = (states[1].pelvis_jacobian - states[0].pelvis_jacobian) / (2 * h)
    np.testing.assert_allclose(state.pelvis_bias_acc, jdot @ data.qvel, atol=1e-4)


def test_soles_match_mujoco_site_by_site(model):
    """Both soles at once (one batched J q̇, all corner Jacobians in one array) against
    MuJoCo's own site quantities, one site at a time; earlier reads stay untouched."""
    reader = StateReader(model)
    first = reader.read(_moving_data(model, seed=4))
    kept = [(f.position.copy(), f.jacobian.copy(), f.corner_jacobians.copy()) for f in first.feet]
    data = _moving_data(model, seed=5)
    state = reader.read(data)
    for side, name in enumerate(("left", "right")):
        foot, site = state.feet[side], model.site(f"{name}_foot").id
        jac = np.zeros((6, model.nv))
        mujoco.mj_jacSite(model, data, jac[3:], jac[:3], site)
        np.testing.assert_allclose(foot.jacobian, jac, atol=1e-12)
        np.testing.assert_allclose(foot.velocity, jac @ data.qvel, atol=1e-12)
        np.testing.assert_allclose(foot.position, data.site_xpos[site], atol=1e-12)
        np.testing.assert_allclose(foot.rotation, data.site_xmat[site].reshape(3, 3), atol=1e-12)
        reach = constants.EFFORT_LIMITS[4:6] / (state.mass * GRAVITY)  # ankle pitch, roll
        body = model.body(constants.FOOT_BODIES[side]).id
        local = (foot.cop_corners - data.xpos[body]) @ data.xmat[body].reshape(3, 3)
        for k, corner in enumerate(("fl", "fr", "rl", "rr")):
            corner_site = model.site(f"{name}_foot_{corner}").id
            corner_jac = np.zeros((3, model.nv))
            mujoco.mj_jacSite(model, data, corner_jac, None, corner_site)
            np.testing.assert_allclose(foot.corner_jacobians[k], corner_jac, atol=1e-12)
            np.testing.assert_allclose(foot.corners[k], data.site_xpos[corner_site], atol=1e-12)
            site_pos = model.site_pos[corner_site]
            np.testing.assert_allclose(local[k], [*np.clip(site_pos[:2], -reach, reach),
                                                  site_pos[2]], atol=1e-12)
        position, jacobian, corner_jacobians = kept[side]
        np.testing.assert_array_equal(first.feet[side].position, position)
        np.testing.assert_array_equal(first.feet[side].jacobian, jacobian)
        np.testing.assert_array_equal(first.feet[side].corner_jacobians, corner_jacobians)
    pelvis = model.body(constants.PELVIS_BODY).id
    np.testing.assert_allclose(state.pelvis_angvel, data.xmat[pelvis].reshape(3, 3)
                               @ data.qvel[3:6], atol=1e-10)


def test_standing_contacts_are_the_soles(model):
    """Under the QP, standing still: the sole forces carry the weight, nothing else touches."""
    controller = BalanceController()
    data = standing_data(model)
    controller.reset(model, data)
    for _ in range(200):
        data.ctrl[:] = controller(model, data)
        mujoco.mj_step(model, data)
    state = StateReader(model).read(data)
    assert not state.non_foot_contact
    weight = state.mass * 9.81
    assert sum(f.normal_force for f in state.feet) == pytest.approx(weight, rel=0.05)


# --- the QP ------------------------------------------------------------------------------


def test_qp_solution_obeys_the_dynamics_and_the_contact_model(model):
    """M q̈ + h = Sᵀ τ + Σ J_iᵀ f_i, f_i in the friction pyramid, |τ| ≤ τ_max."""
    data = _moving_data(model, seed=1)
    state = StateReader(model).read(data)
    cfg = default_config().qp
    qp = WholeBodyQP(model.nv, cfg, model.jnt_range[1:])
    rng = np.random.default_rng(0)
    task = Task("random", rng.normal(size=(6, model.nv)), rng.normal(size=6), 1.0)
    sol = qp.solve(state, [task], (True, True))
    assert sol.status == "solved"
    generalized = np.zeros(model.nv)
    generalized[6:] = sol.torque
    for side in (0, 1):
        for k in range(4):
            generalized += state.feet[side].corner_jacobians[k].T @ sol.corner_forces[side, k]
    np.testing.assert_allclose(state.mass_matrix @ sol.qacc + state.bias, generalized, atol=1e-3)
    f = sol.corner_forces.reshape(-1, 3)
    assert np.all(f[:, 2] >= -1e-6)
    mu = cfg.friction
    assert np.all(np.abs(f[:, :2]) <= mu * f[:, 2:3] + 1e-4)
    assert np.all(np.abs(sol.torque) <= constants.EFFORT_LIMITS + 1e-6)
    for side in (0, 1):  # the stance soles do not accelerate (contact constraint)
        foot = state.feet[side]
        acc = foot.jacobian @ sol.qacc + foot.bias_acc
        np.testing.assert_allclose(acc, -cfg.contact_kd * foot.velocity, atol=1e-4)


def _reference_problem(qp: WholeBodyQP, state, tasks: list[Task], stance: tuple[bool, bool]):
    """The QP of the module docstring assembled the straightforward way (block by block,
    one corner at a time): (H, g, A, b, C, l, u, l_box, u_box)."""
    cfg, nv = qp.cfg, qp.nv
    g_map = np.hstack([state.feet[s].corner_jacobians[k].T @ qp.basis
                       for s in (0, 1) if stance[s] for k in range(4)])
    nf = g_map.shape[1]
    weights = [np.broadcast_to(np.asarray(t.weight, float), t.target.shape) for t in tasks]
    jtj = sum(t.jacobian.T @ (w[:, None] * t.jacobian) for t, w in zip(tasks, weights,
                                                                       strict=True))
    jtb = sum(t.jacobian.T @ (w * t.target) for t, w in zip(tasks, weights, strict=True))
    hess = np.block([[jtj + cfg.w_qacc * np.eye(nv), np.zeros((nv, nf))],
                     [np.zeros((nf, nv)), cfg.w_force * np.eye(nf)]])
    feet = [state.feet[s] for s in (0, 1) if stance[s]]
    a_eq = np.vstack([np.hstack([state.mass_matrix[:6], -g_map[:6]])]
                     + [np.hstack([f.jacobian, np.zeros((6, nf))]) for f in feet])
    b_eq = np.concatenate([-state.bias[:6]]
                          + [-f.bias_acc - cfg.contact_kd * f.velocity for f in feet])
    c_in = np.hstack([state.mass_matrix[6:], -g_map[6:]])
    tau_max = constants.EFFORT_LIMITS * cfg.torque_limit_scale
    q, qd, horizon = state.qpos[7:], state.qvel[6:], cfg.limit_horizon
    box = [np.concatenate([np.full(6, sign * 1e10), 2.0 * (limit - q - qd * horizon) / horizon**2,
                           np.full(nf, bound)])
           for sign, limit, bound in ((-1, qp.q_lo, 0.0), (1, qp.q_hi, cfg.max_corner_force))]
    return (hess, np.concatenate([-jtb, np.zeros(nf)]), a_eq, b_eq, c_in,
            -tau_max - state.bias[6:], tau_max - state.bias[6:], *box)


def test_qp_problem_is_the_formula_of_the_module_docstring(model):
    """The problem assembled in the per-stance arrays kept between ticks equals the
    straightforward assembly, tick after tick and after a tick with a NaN task."""
    reader = StateReader(model)
    qp = WholeBodyQP(model.nv, default_config().qp, model.jnt_range[1:])
    qp.recorder = []
    rng = np.random.default_rng(7)
    for seed, stance in enumerate([(True, True), (True, False), (True, True), (False, True),
                                   (True, True)]):
        state = reader.read(_moving_data(model, seed=10 + seed))
        tasks = [Task("a", rng.normal(size=(6, model.nv)), rng.normal(size=6), 3.0),
                 Task("b", rng.normal(size=(4, model.nv)), rng.normal(size=4),
                      rng.uniform(0.5, 2.0, 4))]
        if seed == 2:
            qp.solve(state, [Task("nan", tasks[0].jacobian, np.full(6, np.nan), 1.0)], stance)
        qp.solve(state, tasks, stance)
        problem = qp.recorder[-1]
        assert problem.stance == stance
        for got, want in zip(problem.args(), _reference_problem(qp, state, tasks, stance),
                             strict=True):
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
    assert len(qp.recorder) == 5  # the NaN problem never reached the solver


def test_pyramid_basis_edges_lie_on_the_cone():
    basis = pyramid_basis(0.5)
    np.testing.assert_allclose(np.linalg.norm(basis, axis=0), 1.0)
    np.testing.assert_allclose(np.hypot(basis[0], basis[1]), 0.5 * basis[2])


def test_infeasible_qp_falls_back_to_the_relaxed_problem(model):
    """No contact force allowed and tiny torque limits: only the relaxed QP is feasible."""
    cfg = default_config()
    cfg.qp.max_corner_force = 0.0
    cfg.qp.torque_limit_scale = 0.05
    controller = BalanceController(cfg)
    data = standing_data(model)
    controller.reset(model, data)
    torque = controller(model, data)
    assert controller.diagnostics.qp_status == "relaxed"
    assert np.all(np.isfinite(torque))
    assert np.all(np.abs(torque) <= constants.EFFORT_LIMITS)
    assert [e.kind for e in controller.events] == ["fallback"]
    assert controller.events[0].message == "QP status relaxed"


def test_failing_qp_repeats_the_last_good_command(model, monkeypatch):
    """A non-finite task (e.g. a bad estimate) never reaches the solver: last good τ."""
    import hybrid_recovery.control.balance_controller as module

    controller = BalanceController()
    data = standing_data(model)
    controller.reset(model, data)
    good = controller(model, data)
    assert controller.diagnostics.qp_status == "solved"
    real = module.dcm_command

    def broken(*args, **kwargs):
        cmd = real(*args, **kwargs)
        cmd.com_acc[:] = np.nan
        return cmd

    monkeypatch.setattr(module, "dcm_command", broken)
    torque = controller(model, data)
    assert controller.diagnostics.qp_status == "last_good"
    np.testing.assert_array_equal(torque, good)
    fresh = BalanceController()
    fresh.reset(model, data)
    torque = fresh(model, data)  # no good command yet: joint damping
    assert fresh.diagnostics.qp_status == "damping"
    np.testing.assert_allclose(torque, -constants.KD * data.qvel[6:])


def test_nan_state_is_a_clear_error(model):
    controller = BalanceController()
    data = standing_data(model)
    controller.reset(model, data)
    data.qvel[10] = np.nan
    with pytest.raises(ValueError) as info:
        controller(model, data)
    assert str(info.value) == NAN_STATE_MESSAGE
    assert NAN_STATE_MESSAGE == "BalanceController: the state has NaN or inf entries (qpos or qvel)"


def test_qp_controller(model):
    from hybrid_recovery.controllers import make

    controller = make("qp")
    assert controller.output == "torque" and controller.physics_dt == model.opt.timestep
    data = standing_data(model)
    controller.reset(model, data)
    assert controller(model, data).shape == (27,)
    assert controller.info() == {"strategy": "stand", "steps": 0, "qp_went_down": False,
                                 "qp_fallbacks": 0}
    with pytest.raises(ValueError) as info:
        make("onnx")
    assert str(info.value) == "controller 'onnx' needs a policy path: onnx:PATH"


def test_model_without_sole_sites_is_refused():
    from hybrid_recovery.control.torque_model import torque_spec

    spec = torque_spec()
    spec.delete(spec.site("left_foot_fl"))
    with pytest.raises(ValueError) as info:
        StateReader(spec.compile())
    assert str(info.value) == ("model has no site 'left_foot_fl': the QP controller needs the "
                               "sole and IMU sites of models/h1_2/h1_2.xml")
