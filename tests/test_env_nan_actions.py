"""A non-finite action is a fault of its env alone: that env is stepped with a zero action,
reset, counted and logged as ``termination/nan``; nothing non-finite reaches the MDP."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.terminations import TERMINATIONS

NUM_ENVS = 4


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 5
    cfg.curriculum.enabled = False
    cfg.pose_weights = {"standing": 1.0}
    return RecoveryEnv(cfg)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_action_resets_that_env_alone(env, bad):
    for _ in range(3):  # episodes under way
        env.step(torch.zeros(NUM_ENVS, env.num_actions))
    steps = env.episode_length_buf.clone()
    resets = env.nan_resets
    actions = torch.full((NUM_ENVS, env.num_actions), 0.5)
    actions[1, 3] = bad  # one joint of one env
    obs, reward, done, extras = env.step(actions)
    for group in ("policy", "critic"):
        assert torch.isfinite(obs[group]).all()
    assert torch.isfinite(reward).all() and reward[1] == 0.0
    assert done[1] and not done[[0, 2, 3]].any()
    assert env.nan_resets == resets + 1
    log = extras["log"]
    assert log["termination/nan"].tolist() == [1.0]  # the one finished episode: env 1
    assert all(log[f"termination/{t}"].tolist() == [0.0] for t in TERMINATIONS if t != "nan")
    assert log["episode/nan_resets_total"] == float(resets + 1)
    assert env.episode_length_buf[1] == 0  # a new episode
    np.testing.assert_array_equal(env.episode_length_buf[[0, 2, 3]].numpy(),
                                  (steps[[0, 2, 3]] + 1).numpy())
    # the new episode's observation has no previous action; the others keep theirs
    assert (obs["critic"][1, -17 - 27:-17] == 0).all()
    assert (obs["critic"][0, -17 - 27:-17] == 0.5).all()
    obs, reward, done, _ = env.step(torch.zeros(NUM_ENVS, env.num_actions))
    assert torch.isfinite(reward).all() and torch.isfinite(obs["critic"]).all()
    assert env.nan_resets == resets + 1
