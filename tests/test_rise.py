"""The QP's rise from a crouch: the profile, the standing height, and rises in MuJoCo."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control import BalanceController, default_config, load_torque_model
from hybrid_recovery.control.config import RiseConfig
from hybrid_recovery.control.rise import (
    min_jerk,
    reset_step_target,
    standing_com_height,
    standing_sole_width,
)
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import start_state
from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS, UPRIGHT_COM_HEIGHT
from hybrid_recovery.sim.initial_states import seat_single


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_torque_model()


def _start(model: mujoco.MjModel, pose: str, seed: int) -> mujoco.MjData:
    """The evaluation's start of ``pose`` (perturbed, seated on the floor)."""
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario(pose=pose, seed=seed), None, "default", CONTROL_DT)
    seat_single(model, data)
    mujoco.mj_forward(model, data)
    return data


def test_min_jerk_profile_ends_at_rest():
    assert min_jerk(0.0) == 0.0 and min_jerk(1.0) == 1.0 and min_jerk(0.5) == pytest.approx(0.5)
    assert min_jerk(-1.0) == 0.0 and min_jerk(2.0) == 1.0
    h = 1e-4  # ṡ and s̈ vanish at both ends (finite differences)
    for end in (0.0, 1.0):
        tau = min(max(end, 2 * h), 1 - 2 * h)
        rate = (min_jerk(tau + h) - min_jerk(tau - h)) / (2 * h)
        acc = (min_jerk(tau + h) - 2 * min_jerk(tau) + min_jerk(tau - h)) / h**2
        assert abs(rate) < 1e-3 and abs(acc) < 0.1
    taus = np.linspace(0, 1, 101)
    assert np.all(np.diff([min_jerk(t) for t in taus]) >= 0)


def test_standing_height_is_where_a_standing_robot_settles(model):
    """h* from kinematics against a robot standing on the floor in q* (contacts solved)."""
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario(pose="standing", noise=0.0), None, "default")
    mujoco.mj_forward(model, data)
    settled = float(data.subtree_com[model.body("pelvis").id, 2])
    assert standing_com_height(model) == pytest.approx(settled, abs=0.01)
    assert standing_com_height(model) > UPRIGHT_COM_HEIGHT + 0.05


def test_reset_step_target_is_beside_the_stance_at_the_standing_width(model):
    """The width from q*'s forward kinematics against the leg's body offsets (q* has the
    hips' yaw and roll at 0 and every other leg joint turns about y, so the sole's lateral
    offset is the sum of the chain's y offsets: an analytic case), and the target on the
    heading's lateral axis (heading 90°)."""
    site = model.site("left_foot").id
    body, offset = model.site_bodyid[site], float(model.site_pos[site][1])
    while model.body(body).name != "pelvis":
        assert np.allclose(model.body_quat[body], [1.0, 0.0, 0.0, 0.0])
        offset += float(model.body_pos[body][1])
        body = model.body_parentid[body]
    width = standing_sole_width(model)
    assert width == pytest.approx(2 * offset, abs=1e-9)
    assert DEFAULT_JOINT_POS[[0, 2, 6, 8]].tolist() == [0.0, 0.0, 0.0, 0.0]
    heading = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # facing +y
    stance = np.array([1.0, 2.0])
    np.testing.assert_allclose(reset_step_target(stance, heading, 0, width), [1.0 - width, 2.0])
    np.testing.assert_allclose(reset_step_target(stance, heading, 1, width), [1.0 + width, 2.0])


def test_a_locked_rise_resets_its_stance_and_stands(model):
    """Squatting seed 28 lands with the hips' yaw and roll at their ranges and locks at a
    CoM of ~0.8 m (docs/experiments.md §15); the stance reset moves the CoM onto one
    sole, steps the other foot to the standing width beside it and rises again (it stood
    in 3 of 3 runs with the joint velocities perturbed by 1e-6 rad/s)."""
    data = _start(model, "squatting", 28)
    controller = BalanceController()
    assert controller.rise(model, data)
    cfg, profile = controller.config.rise, controller._rise.duration
    standing, heights = 0.0, []
    for _ in range(int(10.0 / CONTROL_DT)):
        data.ctrl[:] = controller(model, data)
        mujoco.mj_step(model, data)
        heights.append(float(data.subtree_com[1, 2]))
        standing = standing + CONTROL_DT if heights[-1] > UPRIGHT_COM_HEIGHT else 0.0
        assert np.all(np.abs(data.ctrl) <= model.actuator_ctrlrange[:, 1] + 1e-6)
    kinds = [(e.kind, e.time) for e in controller.events
             if e.kind in ("rise", "stance_reset", "step", "touchdown", "risen")]
    assert [k for k, _ in kinds] == ["rise", "stance_reset", "step", "touchdown", "rise",
                                     "risen"]
    locked_at = kinds[1][1]
    assert locked_at == pytest.approx(profile + cfg.stall_time, abs=0.01)
    assert max(heights[:int(locked_at / CONTROL_DT)]) < cfg.end_com_height  # it was locked
    [step] = controller.steps
    stance = step.first_plan.stance_cop
    assert np.linalg.norm(step.first_plan.target - stance) == pytest.approx(
        standing_sole_width(model), abs=1e-9)
    tilt = np.degrees(np.arccos(data.xmat[1].reshape(3, 3)[2, 2]))
    assert standing > 1.0 and tilt < 20.0 and not controller.rising


def test_no_step_while_the_stance_sole_is_in_the_air(model):
    """A squatting start still falling (both soles 5 cm up, no force on either) with its
    capture point outside the soles: the rise starts, but takes no step until a stance
    sole carries load (a step planned in the air tips it over: squatting seed 8)."""
    data = _start(model, "squatting", 8)
    data.qpos[2] += 0.05
    mujoco.mj_forward(model, data)
    controller = BalanceController()
    assert controller.rise(model, data)
    controller(model, data)
    diag = controller.diagnostics
    assert all(f.normal_force == 0.0 for f in controller._read(data).feet)
    assert diag.margin < -0.05  # ξ outside the soles: a step would be asked for
    assert controller.steps == []


def test_rise_config_is_checked():
    with pytest.raises(ValueError, match=r"RiseConfig.duration must be > 0, got 0.0"):
        RiseConfig(duration=0.0)
    with pytest.raises(ValueError, match=r"RiseConfig.speed must be > 0, got -0.1"):
        RiseConfig(speed=-0.1)
    with pytest.raises(ValueError, match=r"min_duration must be <= duration \(3.0\), got 4.0"):
        RiseConfig(min_duration=4.0)


def test_the_profile_lasts_its_height_over_the_mean_speed(model):
    """T = (h* − h₀)/v̄ within [min_duration, duration]: a deep squat over the longest T,
    a squat high on its feet (the ground chain's, CoM ~0.71 m) faster at the same v̄."""
    cfg = RiseConfig()
    assert cfg.profile_duration(0.56, 0.92) == pytest.approx(3.0)
    assert cfg.profile_duration(0.71, 0.92) == pytest.approx(0.21 / cfg.speed)
    assert cfg.profile_duration(0.40, 0.92) == cfg.duration
    assert cfg.profile_duration(0.90, 0.92) == cfg.min_duration
    data = _start(model, "squatting", 3)
    controller = BalanceController()
    assert controller.rise(model, data)
    rise = controller._rise
    assert rise.duration == pytest.approx((rise.height[1] - rise.height[0]) / cfg.speed)
    # the CoM reference's peak speed is 1.875 v̄ whatever the height (minimum jerk)
    t = rise.start + np.linspace(0.0, rise.duration, 2001)
    speed = np.gradient([rise.height_ref(x) for x in t], t)
    assert speed.max() == pytest.approx(1.875 * cfg.speed, rel=1e-3)


def test_squat_rise_ends_standing(model):
    data = _start(model, "squatting", 3)
    controller = BalanceController()
    assert data.subtree_com[1, 2] < controller.config.min_com_height  # the QP alone declines
    assert controller.rise(model, data) and controller.rising
    assert controller.qp.limit_margin == controller.config.rise.limit_margin == 0.0
    standing = 0.0
    for _ in range(int(5.0 / CONTROL_DT)):
        data.ctrl[:] = controller(model, data)
        mujoco.mj_step(model, data)
        up = data.subtree_com[1, 2] > UPRIGHT_COM_HEIGHT
        standing = standing + CONTROL_DT if up else 0.0
        assert controller.diagnostics is not None and controller.diagnostics.applicable
    assert standing > 1.0 and not controller.rising
    assert controller.qp.limit_margin == controller.config.qp.limit_margin > 0.0  # standing's
    assert [e.kind for e in controller.events if e.kind in ("rise", "risen")] == ["rise", "risen"]
    assert np.all(np.abs(data.ctrl) <= model.actuator_ctrlrange[:, 1] + 1e-6)


def test_no_rise_from_a_kneel(model):
    """A knee on the ground is no crouch on both feet: nothing starts."""
    data = _start(model, "kneeling", 0)
    controller = BalanceController(default_config())
    assert not controller.rise(model, data) and not controller.rising
