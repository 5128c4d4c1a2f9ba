"""Hybrid supervisor: QP while capturable, the policy when down, back with hysteresis."""

from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper

from hybrid_recovery.control import (
    BalanceController,
    HybridSupervisor,
    OnnxPolicy,
    PolicyController,
    SupervisorConfig,
    load_torque_model,
    standing_data,
)
from hybrid_recovery.observation import ACTOR_OBS_DIM, actor_observation
from hybrid_recovery.observation.mujoco_source import ProprioceptionMap, read_proprioception
from hybrid_recovery.robot import constants


def _linear_policy(path: Path, weight: np.ndarray, bias: np.ndarray, outputs: int = 27) -> Path:
    """A stand-in exported policy: actions = obs @ W + b, input 'obs' [1, 87]."""
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["obs", "W"], ["xw"]),
         helper.make_node("Add", ["xw", "b"], ["actions"])],
        "stand_in_policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, ACTOR_OBS_DIM])],
        [helper.make_tensor_value_info("actions", TensorProto.FLOAT, [1, outputs])],
        initializer=[
            helper.make_tensor("W", TensorProto.FLOAT, weight.shape, weight.ravel().tolist()),
            helper.make_tensor("b", TensorProto.FLOAT, bias.shape, bias.ravel().tolist()),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_torque_model()


@pytest.fixture(scope="module")
def policy_path(tmp_path_factory) -> Path:
    rng = np.random.default_rng(0)
    weight = rng.normal(0.0, 1e-3, (ACTOR_OBS_DIM, 27)).astype(np.float32)
    bias = np.zeros(27, np.float32)
    return _linear_policy(tmp_path_factory.mktemp("policy") / "policy.onnx", weight, bias)


def _lying(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Teleports the robot onto its back on the floor, at rest."""
    data.qpos[:] = standing_data(model).qpos
    data.qpos[2] = 0.25
    data.qpos[3:7] = (np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0)  # pitched back 90°
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)


def _standing(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    data.qpos[:] = standing_data(model).qpos
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)


def _run(model, data, controller, seconds: float) -> list[np.ndarray]:
    out = []
    for _ in range(round(seconds / model.opt.timestep)):
        torque = controller(model, data)
        assert np.all(np.isfinite(torque))
        out.append(torque)
        data.ctrl[:] = torque
        mujoco.mj_step(model, data)
    return out


def test_onnx_policy_matches_the_graph(policy_path):
    policy = OnnxPolicy(policy_path)
    obs = np.linspace(-1.0, 1.0, ACTOR_OBS_DIM)
    weight = onnx.numpy_helper.to_array(onnx.load(policy_path).graph.initializer[0])
    np.testing.assert_allclose(policy(obs), obs.astype(np.float32) @ weight, atol=1e-6)


def test_onnx_policy_errors(tmp_path):
    missing = tmp_path / "none.onnx"
    with pytest.raises(FileNotFoundError) as info:
        OnnxPolicy(missing)
    assert str(info.value) == f"ONNX policy not found: {missing}"
    wrong = _linear_policy(tmp_path / "wrong.onnx", np.zeros((ACTOR_OBS_DIM, 5), np.float32),
                           np.zeros(5, np.float32), outputs=5)
    with pytest.raises(ValueError) as info:
        OnnxPolicy(wrong)(np.zeros(ACTOR_OBS_DIM))
    assert str(info.value) == "ONNX policy returned 5 actions, expected 27"
    with pytest.raises(ValueError) as info:
        OnnxPolicy(wrong)(np.zeros(3))
    assert str(info.value) == "observation must have shape (87,), got (3,)"


def test_policy_controller_uses_shared_observation_and_pd_law(model, policy_path):
    data = standing_data(model)
    data.qvel[6:] = np.linspace(-0.5, 0.5, 27)
    mujoco.mj_forward(model, data)
    seen = []
    onnx_policy = OnnxPolicy(policy_path)

    def spy(obs):
        seen.append(obs)
        return onnx_policy(obs)

    controller = PolicyController(spy)
    controller.reset(model, data)
    torque = controller(model, data)
    gyro, quat, *_ = read_proprioception(model, data, ProprioceptionMap.of(model))
    expected_obs = actor_observation(gyro[None], quat[None], data.qpos[None, 7:],
                                     data.qvel[None, 6:], np.zeros((1, 27)))[0]
    np.testing.assert_allclose(seen[0], expected_obs)
    q_ref = constants.DEFAULT_JOINT_POS + 0.3 * onnx_policy(expected_obs)
    expected = np.clip(constants.KP * (q_ref - data.qpos[7:]) - constants.KD * data.qvel[6:],
                       -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
    np.testing.assert_allclose(torque, expected, rtol=1e-6, atol=1e-6)
    controller(model, data)  # within the 20 ms period: no new action
    assert len(seen) == 1


def test_the_policy_stands_first_and_the_qp_holds_its_stance(model, policy_path):
    cfg = SupervisorConfig(to_qp_dwell=0.3, to_qp_blend=0.1)
    supervisor = HybridSupervisor.from_onnx(policy_path, config=cfg)
    data = standing_data(model)
    supervisor.reset(model, data)
    assert supervisor.mode == "policy"
    (start,) = supervisor.events
    assert start.kind == "to_policy"
    assert start.message == "start: the policy stands first (QP applicable)"
    _run(model, data, supervisor, 0.5)
    assert supervisor.mode == "qp" and [e.kind for e in supervisor.events] == [
        "to_policy", "to_qp"]
    assert supervisor.events[1].time >= cfg.to_qp_dwell - model.opt.timestep
    # the QP's posture task holds the joints as the policy left them
    held = supervisor.balance._posture_ref
    assert held is not None and np.abs(held - constants.DEFAULT_JOINT_POS).max() > 1e-4


def test_switches_to_policy_when_down_and_back_with_hysteresis(model, policy_path):
    cfg = SupervisorConfig(to_qp_dwell=0.3, to_qp_blend=0.1)
    supervisor = HybridSupervisor.from_onnx(policy_path, config=cfg)
    data = standing_data(model)
    supervisor.reset(model, data)
    _run(model, data, supervisor, 0.4)
    assert supervisor.mode == "qp" and len(supervisor.events) == 2

    _lying(model, data)  # knocked down
    _run(model, data, supervisor, 0.01)
    assert supervisor.mode == "policy"
    down = supervisor.events[-1]
    assert down.kind == "to_policy" and down.message.startswith("QP not applicable")

    # Hysteresis: standing for less than the dwell time does not hand back...
    _standing(model, data)
    _run(model, data, supervisor, 0.2)
    _lying(model, data)
    _run(model, data, supervisor, 0.05)
    assert supervisor.mode == "policy" and len(supervisor.events) == 3
    # ...standing for longer does, once, after the dwell time.
    _standing(model, data)
    start = data.time
    _run(model, data, supervisor, 0.5)
    assert supervisor.mode == "qp"
    back = supervisor.events[-1]
    assert back.kind == "to_qp" and [e.kind for e in supervisor.events] == [
        "to_policy", "to_qp", "to_policy", "to_qp"]
    assert back.time - start >= cfg.to_qp_dwell - model.opt.timestep


def test_hand_over_to_the_qp_is_smooth(model, policy_path):
    """Torque steps across the policy → QP switch stay small (torque blending)."""
    cfg = SupervisorConfig(to_qp_dwell=0.2, to_qp_blend=0.2)
    supervisor = HybridSupervisor(BalanceController(),
                                  PolicyController(OnnxPolicy(policy_path)), cfg)
    data = standing_data(model)
    supervisor.reset(model, data)
    _lying(model, data)
    _run(model, data, supervisor, 0.01)
    _standing(model, data)
    torques = np.array(_run(model, data, supervisor, 0.6))
    assert supervisor.mode == "qp"
    steps = np.abs(np.diff(torques, axis=0)) / constants.EFFORT_LIMITS
    switch = round((supervisor.events[-1].time - 0.01) / model.opt.timestep)
    assert steps[switch - 5: switch + 100].max() < 0.1


def test_keeps_ankle_and_hip_pushes_and_hands_a_step_over_at_once(model, policy_path):
    """The QP absorbs a push its hip strategy captures and never steps; a push that needs
    a step goes to the policy at once, while the robot is still up."""
    from hybrid_recovery.control import Push, run_episode

    cfg = SupervisorConfig(to_qp_dwell=0.2)
    supervisor = HybridSupervisor.from_onnx(policy_path, config=cfg)
    result = run_episode(model, supervisor, 1.5, push=Push(np.array([150.0, 0.0, 0.0]), 0.6))
    assert result.standing and supervisor.mode == "qp"
    assert [e.kind for e in supervisor.events] == ["to_policy", "to_qp"]
    assert supervisor.balance.steps == []

    result = run_episode(model, supervisor, 0.9, push=Push(np.array([700.0, 0.0, 0.0]), 0.6),
                         keep_diagnostics=True)
    assert [e.kind for e in supervisor.events] == ["to_policy", "to_qp", "to_policy"]
    event = supervisor.events[-1]
    assert event.message.startswith("not capturable by the ankle or hip strategy")
    assert 0.6 <= event.time <= 0.6 + 0.05
    assert supervisor.balance.steps == []
    # ...while the robot is still up: the hand-over comes before the fall.
    assert result.diagnostics[round(event.time / model.opt.timestep) - 1].applicable


def _run_plant(plant, model, data, controller, seconds: float, miss: float = 0.0) -> None:
    """Steps ``plant`` while ``controller`` computes on the nominal ``model``; the motors
    apply the command plus ``miss`` · τ_lim."""
    for _ in range(round(seconds / model.opt.timestep)):
        data.ctrl[:] = controller(model, data) + miss * constants.EFFORT_LIMITS
        mujoco.mj_step(plant, data)


def _tilted_gravity(model: mujoco.MjModel, angle: float) -> mujoco.MjModel:
    tilted = copy.copy(model)
    tilted.opt.gravity[:] = 9.81 * np.array([0.0, np.sin(angle), -np.cos(angle)])
    return tilted


def test_nominal_standing_hands_over_without_a_block(model, policy_path):
    supervisor = HybridSupervisor.from_onnx(policy_path, config=SupervisorConfig(to_qp_dwell=0.3))
    data = standing_data(model)
    supervisor.reset(model, data)
    _run(model, data, supervisor, 0.5)
    assert [e.kind for e in supervisor.events] == ["to_policy", "to_qp"]
    assert supervisor.mismatch is None


def test_gravity_off_the_contact_normal_blocks_the_qp(model, policy_path):
    """Gravity tilted 0.03 rad sideways from the floor's normal, beyond a max_ground_tilt
    of 0.02 rad: the robot stands (it slides off a larger tilt with this stand-in policy),
    but the QP's ground model does not hold."""
    tilted = _tilted_gravity(model, 0.03)
    cfg = SupervisorConfig(to_qp_dwell=0.3, max_ground_tilt=0.02)
    supervisor = HybridSupervisor.from_onnx(policy_path, config=cfg)
    data = standing_data(tilted)
    supervisor.reset(tilted, data)
    _run(tilted, data, supervisor, 0.8)
    assert supervisor.mode == "policy"
    kinds = [(e.kind, e.message) for e in supervisor.events]
    assert kinds[1] == ("qp_blocked", "ground tilted 1.7 deg from the vertical")
    assert len(kinds) == 2  # logged once while the dwell restarts


def test_a_payload_the_model_lacks_blocks_the_qp(model, policy_path):
    plant = copy.copy(model)
    plant.body_mass[model.body(constants.TORSO_BODY).id] += 30.0
    supervisor = HybridSupervisor.from_onnx(policy_path, config=SupervisorConfig(to_qp_dwell=0.3))
    data = standing_data(plant)
    supervisor.reset(model, data)
    _run_plant(plant, model, data, supervisor, 0.8)
    assert supervisor.mode == "policy"
    (blocked,) = [e for e in supervisor.events if e.kind == "qp_blocked"]
    ratio = float(blocked.message.split()[2])
    mass = mujoco.mj_getTotalmass(model)
    assert ratio == pytest.approx((mass + 30.0) / mass, abs=0.05)


def test_motors_that_miss_the_command_latch_the_policy(model, policy_path):
    supervisor = HybridSupervisor.from_onnx(policy_path, config=SupervisorConfig(to_qp_dwell=0.2))
    data = standing_data(model)
    supervisor.reset(model, data)
    _run(model, data, supervisor, 0.4)
    assert supervisor.mode == "qp"
    _run_plant(model, model, data, supervisor, 0.01, miss=0.15)  # 15 % of τ_lim off
    assert supervisor.mode == "policy" and supervisor.mismatch is not None
    assert supervisor.events[-1].kind == "to_policy"
    assert supervisor.events[-1].message == ("torque model mismatch: applied torque off the "
                                             "command by 15% of the limit")
    _run(model, data, supervisor, 0.6)  # nominal again: the QP stays out this episode
    assert supervisor.mode == "policy"
    supervisor.reset(model, data)
    assert supervisor.mismatch is None
