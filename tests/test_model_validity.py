"""The measurements of the QP's model validity: the ground tilt of the contact normals,
the weight ratio of a robot standing still, the torque error against the command."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control.model_validity import (
    foot_body_ids,
    ground_tilt,
    torque_error,
    weight_ratio,
)
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import eval_model, start_state
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.terrain import parse_terrain
from hybrid_recovery.sim.terrain_model import seat_on_terrain


def _stood(terrain: str = "flat", payload: float = 0.0) -> tuple[mujoco.MjModel,
                                                                   mujoco.MjData]:
    """A standing start held by the position servos for 1 s on ``terrain``."""
    model = eval_model(None, 0.005, False, "default", terrain=terrain, payload=payload)
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario("standing", noise=0.0), None, "default")
    seat_on_terrain(model, data, parse_terrain(terrain))
    mujoco.mj_forward(model, data)
    data.ctrl[:] = data.qpos[model.jnt_qposadr[1:1 + constants.NUM_JOINTS]]
    for _ in range(200):
        mujoco.mj_step(model, data)
    return model, data


@pytest.mark.parametrize(("terrain", "degrees"), [("flat", 0.0), ("slope:10", 10.0),
                                                  ("slope:5:90", 5.0)])
def test_ground_tilt_is_the_angle_of_the_contact_normal_to_gravity(terrain, degrees):
    model, data = _stood(terrain)
    assert data.ncon > 0
    assert ground_tilt(model, data, foot_body_ids(model)) == pytest.approx(
        np.radians(degrees), abs=1e-9)


def _mean_ratio(model: mujoco.MjModel, data: mujoco.MjData, mass: float) -> float:
    """ρ averaged over 1 s (the servos hold the robot with some bounce on its soles)."""
    ratios = []
    for _ in range(200):
        mujoco.mj_step(model, data)
        ratios.append(weight_ratio(model, data, mass))
    return float(np.mean(ratios))


def test_weight_ratio_of_a_robot_standing_still_is_its_mass_over_the_models():
    model, data = _stood()
    mass = mujoco.mj_getTotalmass(model)
    assert _mean_ratio(model, data, mass) == pytest.approx(1.0, abs=0.03)
    loaded, data = _stood(payload=30.0)
    assert _mean_ratio(loaded, data, mass) == pytest.approx((mass + 30.0) / mass, abs=0.03)


def test_torque_error_is_the_largest_miss_over_the_limit():
    limit = constants.EFFORT_LIMITS
    command = np.linspace(-2.0, 2.0, constants.NUM_JOINTS) * limit
    assert torque_error(np.clip(command, -limit, limit), command) == 0.0
    applied = np.clip(command, -0.5 * limit, 0.5 * limit)  # motors at half strength
    assert torque_error(applied, command) == pytest.approx(0.5)
    assert torque_error(np.zeros_like(limit), 0.2 * limit) == pytest.approx(0.2)
