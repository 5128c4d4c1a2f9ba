"""r_feet's inputs and the shin axes from the env: each foot's normal force is MuJoCo's own
contact force on it, the sole normals and shin axes are those of Pinocchio's foot and knee
frames; standing robots carry their weight on flat feet with their knees over their
ankles, kneeling ones neither."""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest
import torch

from hybrid_recovery.dynamics import GRAVITY, RobotModel
from hybrid_recovery.dynamics.conventions import qpos_to_pin
from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.rewards import feet_load
from hybrid_recovery.robot import constants

NUM_ENVS = 8


def _held(pose: str, steps: int) -> RecoveryEnv:
    """Envs started in ``pose`` whose PD targets hold the start joints for ``steps``
    (standing: the default pose, as the settled starts carry the pool's joint noise)."""
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 5
    cfg.curriculum.enabled = False  # no pushes
    cfg.pose_weights = {pose: 1.0}
    dr = cfg.domain_rand  # starts exactly in the pose: held still, none tips over
    dr.init_base_pos = dr.init_base_rot = dr.init_joint_pos = 0.0
    env = RecoveryEnv(cfg)
    hold = (env._state["q"] - constants.DEFAULT_JOINT_POS) / cfg.action_scale
    if pose == "standing":
        hold[:] = 0.0
    for _ in range(steps):
        env.step(torch.from_numpy(hold.astype(np.float32)))
    return env


@pytest.fixture(scope="module")
def standing():
    return _held("standing", 20)  # 0.4 s: landed; later some randomised robots tip over


@pytest.mark.parametrize("i", [0, 3, 6])
def test_foot_forces_are_mujocos_contact_forces_on_each_foot(standing, i):
    env = standing
    env.sims.forward(np.arange(NUM_ENVS))  # contact forces at the state itself
    env._read_state()
    model, data = env.sims.get_model(i), env.sims.get_data(i)
    mujoco.mj_forward(model, data)
    want, wrench = np.zeros(2), np.zeros(6)
    for k, contact in enumerate(data.contact[:data.ncon]):
        mujoco.mj_contactForce(model, data, k, wrench)
        bodies = model.geom_bodyid[[contact.geom1, contact.geom2]]
        want += wrench[0] * np.isin(env.feet, bodies)
    np.testing.assert_allclose(env._state["foot_force"][i], want, rtol=1e-9)
    weight = env.randomizer.mass[i, 1:].sum() * GRAVITY
    assert (want > 0.2 * weight).all()  # both feet bear load


def test_standing_robots_carry_their_weight_on_flat_feet(standing):
    env = standing
    still = np.abs(env._state["com_vel"]).max(1) < 0.05
    assert still.sum() >= NUM_ENVS // 2
    rs = env._reward_state(np.zeros(NUM_ENVS, bool))
    assert (feet_load(rs, env.cfg.rewards, env.h_star)[still] > 0.75).all()


@pytest.mark.parametrize("i", [0, 5])
def test_sole_normals_are_the_pinocchio_foot_frames_z(standing, i):
    env = _held("kneeling", 5) if i == 5 else standing  # tilted feet too
    robot = RobotModel(env.sims.get_model(i))
    pin.framesForwardKinematics(robot.model, robot.data, qpos_to_pin(env.qpos[i].copy()))
    want = [robot.data.oMf[robot.model.getFrameId(name)].rotation[2, 2]
            for name in constants.FOOT_BODIES]
    np.testing.assert_allclose(env._state["foot_up"][i], want, atol=1e-9)


@pytest.mark.parametrize("i", [1, 4])
def test_shin_axes_are_the_pinocchio_ankle_to_knee_directions(standing, i):
    env = _held("kneeling", 5) if i == 4 else standing
    robot = RobotModel(env.sims.get_model(i))
    pin.framesForwardKinematics(robot.model, robot.data, qpos_to_pin(env.qpos[i].copy()))
    want = []
    for side in ("left", "right"):
        knee, ankle = (robot.data.oMf[robot.model.getFrameId(f"{side}_{link}_link")].translation
                       for link in ("knee", "ankle_pitch"))
        want.append((knee - ankle)[2] / np.linalg.norm(knee - ankle))
    assert [f"{side}_knee_link" for side in ("left", "right")] == list(constants.KNEE_BODIES)
    np.testing.assert_allclose(env._state["shin_up"][i], want, atol=1e-9)


def test_a_kneeling_robot_has_no_weight_on_flat_feet_and_its_shins_down():
    env = _held("kneeling", 25)
    rs = env._reward_state(np.zeros(NUM_ENVS, bool))
    assert (env._state["foot_up"] < 0.0).all()  # soles facing back, toes on the ground
    assert (feet_load(rs, env.cfg.rewards, env.h_star) == 0.0).all()
    assert (env._state["shin_up"] < 0.0).all()  # the feet behind, raised on their toes
