"""The QP balance controller in closed loop: standing, ankle/hip, capture steps, the ground."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control import (
    BalanceController,
    Push,
    SensorNoise,
    Strategy,
    default_config,
    load_torque_model,
    run_episode,
    standing_data,
)
from hybrid_recovery.control.polygon import signed_distance_scalar


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_torque_model()


def test_stands_still_for_10_s(model):
    controller = BalanceController()
    result = run_episode(model, controller, 10.0, keep_diagnostics=True)
    drift = np.linalg.norm(result.com - result.com[0], axis=1).max()
    assert drift < 0.01
    assert result.standing and result.finite
    assert controller.max_strategy == Strategy.STAND
    assert {d.qp_status for d in result.diagnostics} == {"solved"}
    assert controller.events == []


def test_small_push_is_rejected_without_stepping(model):
    controller = BalanceController()
    result = run_episode(model, controller, 2.0, push=Push(np.array([100.0, 0.0, 0.0]),
                                                         start=0.3))
    assert result.standing
    assert controller.steps == []
    assert Strategy.ANKLE <= controller.max_strategy <= Strategy.HIP
    assert np.linalg.norm(result.com[-1, :2] - result.com[0, :2]) < 0.02


def test_hip_strategy_holds_a_push_the_ankles_cannot(model):
    cfg = default_config()
    cfg.stepping.enabled = False
    controller = BalanceController(cfg)
    result = run_episode(model, controller, 2.5, push=Push(np.array([200.0, 0.0, 0.0]),
                                                         start=0.3), keep_diagnostics=True)
    assert result.standing and controller.max_strategy == Strategy.HIP
    assert max(d.margin for d in result.diagnostics) > 0.0
    assert min(d.margin for d in result.diagnostics) < 0.0  # ξ left the support polygon


def test_large_push_steps_into_the_capture_region_and_ends_standing(model):
    controller = BalanceController()
    result = run_episode(model, controller, 2.5, push=Push(np.array([280.0, 0.0, 0.0]),
                                                         start=0.3))
    assert result.standing and result.finite
    assert controller.max_strategy == Strategy.STEP
    assert len(controller.steps) >= 1
    step = controller.steps[0]
    assert step.first_plan.capturable and step.last_plan.capturable
    assert step.touchdown is not None
    # The sole lands where the last re-plan put it, inside its 1-step capture region
    # (5 mm for tracking).
    assert signed_distance_scalar(step.touchdown, step.last_plan.region) < 0.005
    assert np.linalg.norm(step.touchdown - step.last_plan.target) < 0.01
    assert step.touchdown[0] > 0.15  # a forward step


def test_noisy_measurements_and_a_push(model):
    noise = SensorNoise(joint_pos=0.002, joint_vel=0.05, base_rot=0.003, base_angvel=0.02,
                        base_linvel=0.01)
    controller = BalanceController()
    result = run_episode(model, controller, 2.0, push=Push(np.array([0.0, 150.0, 0.0]),
                                                         start=0.3), noise=noise, seed=1)
    assert result.standing and result.finite


def test_on_the_ground_it_reports_not_applicable(model):
    controller = BalanceController()
    data = standing_data(model)
    controller.reset(model, data)
    data.qpos[2] = 0.25
    data.qpos[3:7] = (np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0)
    mujoco.mj_forward(model, data)
    torque = controller(model, data)
    diag = controller.diagnostics
    assert not diag.applicable and diag.strategy == Strategy.NOT_APPLICABLE
    assert diag.qp_status == "not_applicable"
    assert diag.reason.startswith("CoM height")
    assert np.all(np.isfinite(torque))
    assert controller.events[-1].kind == "not_applicable"
