"""The DC motor model: the torque–speed curve against its formula, in MuJoCo's actuators
(evaluation and the training env), and the manufacturer's velocity limits."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest
import torch
from conftest import REFERENCE_DIR

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import EnvConfig, apply_overrides
from hybrid_recovery.evaluation.motor_use import MotorUse
from hybrid_recovery.evaluation.trial import eval_model
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.actuator import check_actuator, dc_torque_limits, torque_limits

KNEE = constants.JOINT_NAMES.index("left_knee_joint")  # τ_lim 300 N·m, ω_max 14 rad/s


def _knee(speed: float, ratio: float = 1.0) -> tuple[float, float]:
    velocity = np.zeros(constants.NUM_JOINTS)
    velocity[KNEE] = speed
    low, high = dc_torque_limits(velocity, constants.EFFORT_LIMITS, saturation_ratio=ratio)
    return float(low[KNEE]), float(high[KNEE])


def test_at_rest_every_joint_has_its_effort_limit():
    low, high = dc_torque_limits(np.zeros((3, 27)), constants.EFFORT_LIMITS)
    assert np.array_equal(high, np.tile(constants.EFFORT_LIMITS, (3, 1)))
    assert np.array_equal(low, -high)


def test_at_the_velocity_limit_no_driving_torque_is_left_but_full_braking():
    assert _knee(14.0) == (-300.0, 0.0)
    assert _knee(-14.0) == (0.0, 300.0)


@pytest.mark.parametrize(("speed", "ratio", "expected"), [
    (7.0, 1.0, (-300.0, 150.0)),     # τ_sat (1 − ½) = 150 driving; braking τ_lim
    (-7.0, 1.0, (-150.0, 300.0)),
    (3.5, 1.5, (-300.0, 300.0)),     # 450 · ¾ = 337.5 > τ_lim: still the limit
    (7.0, 1.5, (-300.0, 225.0)),     # 450 · ½
    (21.0, 1.0, (-300.0, 0.0)),      # beyond ω_max: braking only (the formula's −150 → 0)
    (42.0, 1.0, (-300.0, 0.0)),      # the formula's interval would be empty: 0 kept
])
def test_the_curve_against_its_formula(speed, ratio, expected):
    assert _knee(speed, ratio) == pytest.approx(expected)


def test_ideal_motors_give_the_limit_at_any_speed():
    low, high = torque_limits("ideal", np.full(27, 100.0), constants.EFFORT_LIMITS)
    assert np.array_equal(high, constants.EFFORT_LIMITS) and np.array_equal(low, -high)


def test_an_unknown_motor_model_is_refused_in_one_line():
    with pytest.raises(ValueError) as info:
        check_actuator("servo")
    assert str(info.value) == "unknown actuator 'servo': choose one of ['ideal', 'dc']"
    with pytest.raises(ValueError) as info:
        EnvConfig(actuator="servo")  # type: ignore[arg-type]
    assert str(info.value) == "unknown actuator 'servo': choose one of ['ideal', 'dc']"
    with pytest.raises(ValueError) as info:
        apply_overrides(default_config(), {"actuator": "servo"})
    assert str(info.value) == "config key 'actuator' must be one of 'ideal', 'dc', got 'servo'"
    with pytest.raises(ValueError) as info:
        EnvConfig(actuator="dc", backend="warp")
    assert str(info.value) == "actuator 'dc' needs the batch backend, got 'warp'"


def test_the_velocity_limits_are_the_manufacturers():
    urdf = REFERENCE_DIR / "h1_2_handless.urdf"
    if not urdf.is_file():
        pytest.skip(f"{urdf} not found (../shared absent)")
    text = urdf.read_text()
    for name, limit in zip(constants.JOINT_NAMES, constants.VELOCITY_LIMITS, strict=True):
        joint = re.search(rf'<joint name="{name}".*?<limit[^>]*velocity="([^"]+)"', text, re.S)
        assert joint is not None and float(joint.group(1)) == limit, name


def test_mujoco_applies_the_curve_in_an_evaluation_model():
    """A knee at 10 rad/s whose PD asks for more than the curve gives: MuJoCo's actuator
    force is the curve's 300 (1 − 10/14) ≈ 85.7 N·m; braking it keeps 300."""
    model = eval_model(None, 0.005, False, "default", actuator="dc")
    data = mujoco.MjData(model)
    motors = MotorUse(model, "dc")
    knee = model.jnt_dofadr[model.actuator_trnid[KNEE, 0]]
    for target, expected in ((10.0, 300.0 * (1 - 10 / 14)), (-10.0, -300.0)):
        data.qvel[:] = 0.0
        data.qvel[knee] = 10.0
        data.ctrl[:] = data.qpos[model.jnt_qposadr[model.actuator_trnid[:, 0]]]
        data.ctrl[KNEE] += target
        motors.before_step(model, data)
        mujoco.mj_forward(model, data)
        assert data.actuator_force[KNEE] == pytest.approx(expected)


def test_the_env_steps_with_the_curve_in_its_actuators(monkeypatch):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed, cfg.actuator = 4, 1, 2, "dc"
    cfg.curriculum.enabled = False
    cfg.pose_weights = {"standing": 1.0}
    env = RecoveryEnv(cfg)
    assert env.motors is not None
    speeds = []
    apply = env.motors.apply
    monkeypatch.setattr(env.motors, "apply", lambda: (speeds.append(
        env.qvel[:, env.motors.dadr].copy()), apply()))
    force = env.sims.bind("actuator_force")
    rng = np.random.default_rng(0)
    at_curve = 0
    for _ in range(10):
        env.step(torch.from_numpy(rng.uniform(-3, 3, (4, 27)).astype(np.float32)))
        assert len(speeds) == cfg.decimation  # rewritten before every substep
        low, high = dc_torque_limits(speeds[-1], env.motors.effort)
        assert (force >= low - 1e-9).all() and (force <= high + 1e-9).all()
        at_curve += int(((np.isclose(force, high) & (high < env.motors.effort - 1e-6))
                         | (np.isclose(force, low) & (low > -env.motors.effort + 1e-6))).sum())
        speeds.clear()
    assert at_curve > 0  # the curve, not only the effort limit, bounded some torque
