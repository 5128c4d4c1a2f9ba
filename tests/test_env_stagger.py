"""Staggered episodes: spread over the episode length, their cut-short outcomes left out
of the logs and of every window, and the runner staggers when training starts."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.training import TrainConfig, train


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 8, 1, 5
    cfg.episode_length_s = 0.4  # T = 20 steps
    cfg.curriculum.window = 10_000  # a window that keeps every outcome it is given
    return RecoveryEnv(cfg)


def test_staggered_episodes_end_apart_and_are_not_counted(env):
    env.stagger()
    elapsed = env.episode_length_buf.numpy().copy()
    assert ((elapsed >= 0) & (elapsed < env.max_episode_length)).all()
    assert len(set(elapsed)) > 1 and not env.counted.any()
    zero = torch.zeros(env.num_envs, env.num_actions)
    windows = len(env.curriculum.state_dict()["outcomes"]), len(env.assist.state_dict()["outcomes"])
    ended_at = np.full(env.num_envs, -1)
    for t in range(env.max_episode_length):
        _, _, done, extras = env.step(zero)
        first = done.numpy() & (ended_at < 0)
        ended_at[first] = t
        assert extras["log"] == {}  # only staggered episodes have ended
    assert (ended_at >= 0).all() and len(set(ended_at)) > 1  # all ended, not at once
    assert (len(env.curriculum.state_dict()["outcomes"]),
            len(env.assist.state_dict()["outcomes"])) == windows
    assert env.counted.all()  # every episode since is counted
    logged = 0
    for _ in range(env.max_episode_length):
        _, _, done, extras = env.step(zero)
        if done.any():
            assert len(extras["log"]["episode/success"]) == int(done.sum())
            logged += int(done.sum())
    assert logged >= env.num_envs  # each env's next episode ended within T steps


def test_a_reset_starts_the_episodes_reward_sums_afresh(env):
    """Also of an episode that was not logged (staggered, or reset after a NaN)."""
    for sums in env.episode_sums.values():
        sums[:] = 5.0
    env._reset(np.array([1, 3]))
    for sums in env.episode_sums.values():
        assert (sums[[1, 3]] == 0.0).all() and (np.delete(sums, [1, 3]) == 5.0).all()


def test_the_runner_staggers_when_training_starts_and_resumes(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(RecoveryEnv, "stagger", lambda self: calls.append(self.num_envs))
    cfg = TrainConfig(num_envs=8, iterations=1, save_interval=1, num_threads=1)
    train(tmp_path / "run", cfg)
    cfg.iterations = 2
    train(tmp_path / "run", cfg, resume=True)
    assert calls == [8, 8]
    cfg.stagger_start, cfg.iterations = False, 1
    train(tmp_path / "off", cfg)
    assert calls == [8, 8]
