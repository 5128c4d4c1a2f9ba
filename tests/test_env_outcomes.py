"""Episode outcomes: counted once per episode, a rise as soon as it happens and a
failure when the episode ends; each episode's reward sums start afresh."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import BridgeConfig

DONES = ("torso_contact", "stuck_low", "nan", "timeout")


def _env(bridge: bool) -> RecoveryEnv:
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 8, 1, 4
    cfg.pose_weights = {"kneeling": 1.0}
    cfg.curriculum.window = 10_000  # windows that keep every outcome they are given
    if bridge:
        cfg.bridge = BridgeConfig(levels=4, window=10_000)
    return RecoveryEnv(cfg)


@pytest.fixture()
def env():
    return _env(bridge=True)


@pytest.mark.parametrize("bridge", [True, False])
def test_a_rise_is_counted_when_it_happens_and_a_failure_when_the_episode_ends(bridge):
    """In the bridge's window when the episodes start on it, else in the curriculum's."""
    env = _env(bridge)
    counted = (lambda: list(env.bridge._outcomes["kneeling"])) if bridge else \
        (lambda: list(env.curriculum._outcomes))
    zero = torch.zeros(env.num_envs, env.num_actions)
    ids = np.arange(env.num_envs)
    env.stood_up[:4] = True  # four rose during this step (up 1 s), none has ended
    env.step(zero)
    assert counted() == [True] * 4
    env.step(zero)  # counted once
    assert len(counted()) == 4
    dones = {name: np.zeros(env.num_envs, bool) for name in DONES}
    env._episode_log(ids, dones)  # all end: the other four, not up, count as failures
    assert counted() == [True] * 4 + [False] * 4
    if bridge:  # a bridge's starts are its own, not the curriculum's
        assert list(env.curriculum._outcomes) == []
    env._episode_log(ids, dones)  # the same episodes again: nothing more
    assert len(counted()) == 8
    env._reset(ids)  # new episodes are counted afresh
    env._episode_log(ids[:2], dones)
    assert len(counted()) == 10


def test_a_rise_from_an_earlier_level_does_not_count_for_the_current_one(env):
    env.stood_up[:] = True
    env.start_level[:] = np.arange(env.num_envs) % 2  # half began at level 1, half at 0
    env.bridge.level["kneeling"] = 1
    env.step(torch.zeros(env.num_envs, env.num_actions))
    assert list(env.bridge._outcomes["kneeling"]) == [True] * 4


def test_a_reset_starts_the_episodes_reward_sums_afresh(env):
    """Also of an episode that ends unlogged (reset after a NaN)."""
    env.step(torch.zeros(env.num_envs, env.num_actions))
    for sums in env.episode_sums.values():
        sums[:] = 5.0
    env._reset(np.array([1, 3]))
    for sums in env.episode_sums.values():
        assert (sums[[1, 3]] == 0.0).all() and (np.delete(sums, [1, 3]) == 5.0).all()
