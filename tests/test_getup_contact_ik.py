"""Contact keyframes by placo IK: contacts on the floor, ranges × 0.9, statically held."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.getup.contact_ik import CONTACT_KEYFRAMES, ContactIk
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, contact_points_world
from hybrid_recovery.getup.feasibility import static_feasibility
from hybrid_recovery.robot.mjcf import load_mjmodel


@pytest.fixture(scope="module")
def model():
    return load_mjmodel(floor=False, actuators=False)


@pytest.fixture(scope="module")
def ik(model):
    return ContactIk(model)


@pytest.mark.parametrize("name", sorted(CONTACT_KEYFRAMES))
def test_keyframe_holds_its_contacts_within_ranges_and_statically(model, ik, name):
    keyframe = CONTACT_KEYFRAMES[name]
    result = ik.solve(keyframe)
    # every load-bearing point on the floor within 1 cm, measured in MuJoCo
    data = mujoco.MjData(model)
    data.qpos[:] = result.qpos
    mujoco.mj_kinematics(model, data)
    for contact, heights in result.contact_heights.items():
        assert np.abs(heights).max() < 0.01, (contact, heights)
        c = FLOOR_CONTACTS[contact]
        body = model.body(c.body).id
        lowest = contact_points_world(c, data.xpos[body], data.xmat[body].reshape(3, 3))[:, 2]
        assert abs(lowest.min()) < 0.01
    # joints within the ranges × 0.9
    lo, hi = model.jnt_range[1:, 0], model.jnt_range[1:, 1]
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    assert np.all(np.abs(result.qpos[7:] - mid) <= 0.9 * half + 1e-9)
    assert result.range_use <= 0.9 + 1e-9
    # and the pose can be held still on those contacts at 1× effort limits
    check = static_feasibility(RobotModel(model), result.qpos, keyframe.contacts)
    assert check.feasible, check.reason
    assert check.worst_ratio < 1.0


def test_urdf_for_placo_has_the_same_kinematics_and_mass(model, ik):
    rng = np.random.default_rng(3)
    qpos = np.zeros(model.nq)
    qpos[2], qpos[3] = 1.0, 1.0
    qpos[7:] = rng.uniform(model.jnt_range[1:, 0], model.jnt_range[1:, 1])
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    for k in range(27):
        ik.robot.set_joint(model.joint(k + 1).name, float(qpos[7 + k]))
    base = np.eye(4)
    base[2, 3] = 1.0
    ik.robot.set_T_world_fbase(base)
    ik.robot.update_kinematics()
    body = model.body("left_wrist_yaw_link").id
    expected = data.xpos[body] + data.xmat[body].reshape(3, 3) @ FLOOR_CONTACTS[
        "left_hand"].points[0]
    np.testing.assert_allclose(ik.robot.get_T_world_frame("left_hand_0")[:3, 3], expected,
                               atol=1e-9)
    assert ik.robot.total_mass() == pytest.approx(float(model.body_subtreemass[1]), rel=1e-9)
