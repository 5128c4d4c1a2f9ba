"""The single-robot Gymnasium wrapper: Gymnasium's own checker, and the episode API."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from hybrid_recovery.envs import default_config
from hybrid_recovery.envs.gym_env import ACTION_BOUND, RecoveryGymEnv
from hybrid_recovery.robot.action import ACTION_CLIP

EPISODE_STEPS = 10


@pytest.fixture(scope="module")
def genv():
    cfg = default_config()
    cfg.curriculum.enabled = False
    cfg.episode_length_s = EPISODE_STEPS * cfg.physics_dt * cfg.decimation
    env = RecoveryGymEnv(cfg)
    yield env
    env.close()


def test_gymnasium_env_checker(genv):
    with warnings.catch_warnings():
        # unbounded observations and the ±10 action box are deliberate
        warnings.simplefilter("ignore")
        check_env(genv, skip_render_check=True)


def test_spaces(genv):
    assert genv.observation_space.shape == (87,)
    assert genv.action_space.shape == (27,)
    assert ACTION_BOUND == ACTION_CLIP


def test_seeded_reset_is_reproducible_and_carries_the_critic(genv):
    obs_1, info_1 = genv.reset(seed=42)
    obs_2, info_2 = genv.reset(seed=42)
    obs_3, _ = genv.reset(seed=43)
    np.testing.assert_array_equal(obs_1, obs_2)
    np.testing.assert_array_equal(info_1["critic"], info_2["critic"])
    assert not np.array_equal(obs_1, obs_3)
    assert obs_1.dtype == np.float32 and obs_1.shape == (87,)
    assert info_1["critic"].shape == (104,)
    # the critic's first 87 entries are the actor's without noise
    assert np.abs(obs_1 - info_1["critic"][:87]).max() < 0.51


@pytest.mark.parametrize("pose,low,high", [("supine", 0.0, 0.4), ("standing", 0.8, 1.1)])
def test_reset_option_forces_the_pose(genv, pose, low, high):
    _, info = genv.reset(seed=0, options={"pose": pose})
    com_height = info["critic"][87 + 2]
    assert low < com_height < high


def test_timeout_truncates_with_the_last_observation(genv):
    genv.reset(seed=1, options={"pose": "supine"})
    action = np.full(27, 0.25, np.float32)
    for k in range(1, EPISODE_STEPS + 1):
        obs, reward, terminated, truncated, info = genv.step(action)
        assert isinstance(reward, float) and np.isfinite(reward)
        if terminated:
            pytest.skip("the episode ended early; no timeout to check")
        assert truncated == (k == EPISODE_STEPS)
    # the episode's last observation (previous action = a), not the next episode's first
    np.testing.assert_array_equal(obs[-27:], action)
    np.testing.assert_array_equal(info["critic"][60:87], action)
    assert info["episode"]["termination/timeout"] == 1.0
    assert "reward/height" in info["episode"]


def test_errors_are_exact(genv):
    genv.reset(seed=0)
    with pytest.raises(ValueError, match=r"^action must have shape \(27,\), got \(26,\)$"):
        genv.step(np.zeros(26))
    with pytest.raises(ValueError, match=r"^unknown pose 'lying': choose one of \["):
        genv.reset(options={"pose": "lying"})
    with pytest.raises(ValueError, match=r"^render_mode must be None or one of \['rgb_array'\], "
                                         r"got 'human'$"):
        RecoveryGymEnv(render_mode="human")
