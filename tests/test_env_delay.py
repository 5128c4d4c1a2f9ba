"""Actuation delay (SPEC §3): a step in the action reaches the PD targets (``ctrl``) exactly
the episode's sampled delay later, measured substep by substep."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.robot import constants

NUM_ENVS = 16


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 5
    cfg.curriculum.enabled = False
    cfg.pose_weights = {"supine": 1.0}  # lying robots: few episodes end within the test
    return RecoveryEnv(cfg)


def delay_substeps(offsets: np.ndarray, decimation: int, candidates: range) -> int:
    """The delay d [substeps] whose history offsets ⌈(d − k) / decimation⌉ match, k < decimation."""
    matches = [d for d in candidates
               if list(offsets) == [max(0, math.ceil((d - k) / decimation))
                                    for k in range(decimation)]]
    assert len(matches) == 1, (offsets, matches)
    return matches[0]


def record_ctrl(env, monkeypatch) -> list[np.ndarray]:
    """Patches the batch's step to record ``ctrl`` as each substep applies it."""
    applied: list[np.ndarray] = []
    step = env.sims.step

    def recording_step(*args, **kwargs):
        applied.append(env.ctrl.copy())
        return step(*args, **kwargs)

    monkeypatch.setattr(env.sims, "step", recording_step)
    return applied


def test_step_change_reaches_ctrl_after_the_sampled_delay(env, monkeypatch):
    dec, dt = env.cfg.decimation, env.cfg.physics_dt
    lo, hi = (round(x / dt) for x in env.cfg.delay_range)
    delays = np.array([delay_substeps(env.delay_offset[i], dec, range(lo, hi + 1))
                       for i in range(NUM_ENVS)])
    assert ((delays * dt >= 0.010 - 1e-9) & (delays * dt <= 0.040 + 1e-9)).all()
    assert len(np.unique(delays)) >= 3  # sampled per env, not one fixed value

    zero = torch.zeros(NUM_ENVS, env.num_actions)
    ended = np.zeros(NUM_ENVS, dtype=bool)  # an episode that ends re-samples its delay
    for _ in range(env.target_hist.shape[1]):  # fill the history with the zero action
        _, _, done, _ = env.step(zero)
        ended |= done.numpy()
    offsets_before = env.delay_offset.copy()
    lo, hi = env.randomizer.jnt_range[:, 1:28].transpose(2, 0, 1)  # targets are clipped
    old = np.clip(constants.DEFAULT_JOINT_POS, lo, hi)
    applied = record_ctrl(env, monkeypatch)
    action = torch.full((NUM_ENVS, env.num_actions), 0.5)
    new = np.clip(constants.DEFAULT_JOINT_POS + env.cfg.action_scale * 0.5, lo, hi)
    for _ in range(3):
        _, _, done, _ = env.step(action)
        ended |= done.numpy()
    ctrl = np.stack(applied, 1)  # (N, 3 * decimation, 27)
    assert ctrl.shape == (NUM_ENVS, 3 * dec, 27)
    kept = np.flatnonzero(~ended)
    assert len(kept) >= NUM_ENVS // 2
    # held within the episode
    np.testing.assert_array_equal(env.delay_offset[kept], offsets_before[kept])
    for i in kept:
        is_new = np.all(ctrl[i] == new[i], axis=1)
        is_old = np.all(ctrl[i] == old[i], axis=1)
        assert (is_new | is_old).all()
        first = int(np.argmax(is_new))
        assert is_new.any() and first == delays[i], (i, first, delays[i])
        assert is_old[:first].all() and is_new[first:].all()


def test_a_new_episode_starts_holding_its_initial_pose(env):
    """After a reset the delayed commands are the start configuration, not the default pose."""
    ids = np.arange(NUM_ENVS)
    env._reset(ids)
    start = env.qpos[:, env.qadr]
    history = env.target_hist.shape[1]
    np.testing.assert_array_equal(env.target_hist, np.repeat(start[:, None], history, 1))
    np.testing.assert_array_equal(env.ctrl, start)
