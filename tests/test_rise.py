"""The QP's rise from a crouch: the profile, the standing height, and rises in MuJoCo."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control import BalanceController, default_config, load_torque_model
from hybrid_recovery.control.config import RiseConfig
from hybrid_recovery.control.rise import min_jerk, standing_com_height
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import start_state
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT
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


def test_rise_config_is_checked():
    with pytest.raises(ValueError, match=r"RiseConfig.duration must be > 0, got 0.0"):
        RiseConfig(duration=0.0)


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
