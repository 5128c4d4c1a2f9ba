"""The env's balance quantities (MuJoCo sensors) against the dynamics layer (Pinocchio).

Each simulation runs on its own randomised masses and inertias, so the reference is
``RobotModel`` built from that simulation's model. The sensors are computed at the state
the last step left (stage VEL), so the comparison is made right after a step.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.observation import ACTOR_OBS_DIM

NUM_ENVS = 8
CHECKED = (0, 3, 7)


@pytest.fixture(scope="module")
def stepped_env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 2
    cfg.curriculum.enabled = False  # randomised masses: the check must use each sim's model
    env = RecoveryEnv(cfg)
    gen = torch.Generator().manual_seed(0)
    for _ in range(15):  # moving robots: non-zero velocities and momenta
        env.step(torch.randn(NUM_ENVS, env.num_actions, generator=gen))
    return env


def reference(env, i):
    robot = RobotModel(env.sims.get_model(i))
    return robot, robot.balance_state(env.qpos[i].copy(), env.qvel[i].copy())


def test_masses_are_randomised(stepped_env):
    masses = [RobotModel(stepped_env.sims.get_model(i)).mass for i in CHECKED]
    assert np.ptp(masses) > 0.1


@pytest.mark.parametrize("i", CHECKED)
def test_sensor_balance_state_equals_pinocchio(stepped_env, i):
    env = stepped_env
    robot, ref = reference(env, i)
    s = env._state
    assert np.abs(ref.com_vel).max() > 1e-3  # a moving robot, not a trivial zero
    np.testing.assert_allclose(s["com"][i], ref.com, atol=1e-6)
    np.testing.assert_allclose(s["com_vel"][i], ref.com_vel, atol=1e-6)
    np.testing.assert_allclose(s["lin"][i], ref.linear_momentum, atol=1e-6)
    np.testing.assert_allclose(s["ang"][i], ref.angular_momentum, atol=1e-6)
    np.testing.assert_allclose(s["cp"][i], ref.capture_point, atol=1e-6)
    assert s["height"][i] == pytest.approx(ref.com[2], abs=1e-6)


@pytest.mark.parametrize("i", CHECKED)
def test_privileged_critic_inputs_are_the_balance_state_in_the_heading_frame(stepped_env, i):
    """A yaw rotation keeps z and the horizontal norm: check both for each 3-vector."""
    env = stepped_env
    _, ref = reference(env, i)
    priv = env.get_observations()["critic"][i, ACTOR_OBS_DIM:].double().numpy()
    assert priv.shape == (17,)
    com_rel = ref.com - np.r_[env.qpos[i, :2], 0.0]
    for got, want in ((priv[0:3], com_rel), (priv[3:6], ref.com_vel),
                      (priv[9:12], ref.linear_momentum), (priv[12:15], ref.angular_momentum)):
        scale = max(1.0, np.abs(want).max())
        assert got[2] == pytest.approx(want[2], abs=1e-5 * scale)
        assert np.hypot(*got[:2]) == pytest.approx(np.hypot(*want[:2]), abs=1e-5 * scale)
    cp_rel = ref.capture_point - ref.com[:2]
    assert np.hypot(*priv[15:17]) == pytest.approx(np.hypot(*cp_rel), abs=1e-5)
    # ξ − c = ċ/ω: along the CoM velocity in any frame
    np.testing.assert_allclose(priv[15:17], priv[3:5] / ref.omega, atol=1e-5)


def test_net_wrench_is_the_momentum_difference(stepped_env):
    env = stepped_env
    before = np.concatenate([env._state["lin"], env._state["ang"]], 1).copy()
    _, _, done, _ = env.step(torch.zeros(NUM_ENVS, env.num_actions))
    after = np.concatenate([env._state["lin"], env._state["ang"]], 1)
    keep = ~done.numpy()
    np.testing.assert_allclose(env._state["net_force"][keep],
                               (after[keep, :3] - before[keep, :3]) / env.dt)
    np.testing.assert_allclose(env._state["net_torque"][keep],
                               (after[keep, 3:] - before[keep, 3:]) / env.dt)
