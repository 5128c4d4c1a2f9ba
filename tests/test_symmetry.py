"""The left/right mirror used for symmetry augmentation."""

from __future__ import annotations

import mujoco
import numpy as np
import torch
from tensordict import TensorDict

from hybrid_recovery.observation import actor_observation
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import load_mjmodel
from hybrid_recovery.training.symmetry import mirror_batch, mirror_critic_obs, mirror_joints


def test_mirror_is_an_involution():
    x = torch.randn(5, 104)
    np.testing.assert_allclose(mirror_critic_obs(mirror_critic_obs(x)), x)
    a = torch.randn(5, 27)
    np.testing.assert_allclose(mirror_joints(mirror_joints(a)), a)


def test_default_pose_and_limits_are_mirror_symmetric():
    q = torch.as_tensor(constants.DEFAULT_JOINT_POS, dtype=torch.float32)
    np.testing.assert_allclose(mirror_joints(q), q, atol=1e-7)
    model = load_mjmodel()
    lo, hi = (torch.as_tensor(model.jnt_range[1:, i], dtype=torch.float32) for i in (0, 1))
    mirrored = torch.stack([mirror_joints(lo), mirror_joints(hi)])
    np.testing.assert_allclose(mirrored.min(0).values, lo, atol=1e-6)
    np.testing.assert_allclose(mirrored.max(0).values, hi, atol=1e-6)


def test_mirrored_state_gives_mirrored_observation():
    """Reflect a random state through the x–z plane in MuJoCo: the observation follows."""
    model = load_mjmodel()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(0)
    imu = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "imu")
    model.site_pos[imu, 1] = 0.0  # the real IMU sits 19 mm off the sagittal plane

    def obs(qpos, qvel):
        data.qpos[:], data.qvel[:] = qpos, qvel
        mujoco.mj_forward(model, data)
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, imu, vel, 1)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, data.site_xmat[imu])
        return actor_observation(vel[None, :3], quat[None], qpos[None, 7:], qvel[None, 6:],
                                 np.zeros((1, 27)))

    qpos = np.zeros(model.nq)
    qpos[2] = 1.0
    roll, pitch = 0.3, -0.2
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, [roll, pitch, 0.0], "xyz")
    qpos[3:7] = quat
    qpos[7:] = constants.DEFAULT_JOINT_POS + rng.uniform(-0.2, 0.2, 27)
    qvel = rng.normal(size=model.nv)
    mirrored_q = qpos.copy()
    mujoco.mju_euler2Quat(quat, [-roll, pitch, 0.0], "xyz")
    mirrored_q[3:7] = quat
    mirrored_q[7:] = mirror_joints(torch.as_tensor(qpos[7:])).numpy()
    mirrored_v = qvel.copy()
    mirrored_v[0:3] *= [1, -1, 1]
    mirrored_v[3:6] *= [-1, 1, -1]
    mirrored_v[6:] = mirror_joints(torch.as_tensor(qvel[6:])).numpy()
    expected = mirror_critic_obs(torch.as_tensor(obs(qpos, qvel)))[0, :87]
    np.testing.assert_allclose(obs(mirrored_q, mirrored_v)[0], expected.numpy(), atol=1e-5)


def test_mirror_batch_doubles_the_batch():
    obs = TensorDict({"policy": torch.randn(4, 87), "critic": torch.randn(4, 104)},
                     batch_size=[4])
    out, act = mirror_batch(obs=obs, actions=torch.randn(4, 27))
    assert out["policy"].shape == (8, 87) and out["critic"].shape == (8, 104)
    assert act.shape == (8, 27)


def test_ppo_with_symmetry_augmentation_runs(tmp_path):
    from hybrid_recovery.training import TrainConfig, train

    cfg = TrainConfig(num_envs=4, iterations=1, save_interval=1, num_threads=1)
    cfg.ppo.symmetry = True
    runner = train(tmp_path, cfg)
    assert runner.alg.symmetry is not None and runner.alg.symmetry.use_data_augmentation
