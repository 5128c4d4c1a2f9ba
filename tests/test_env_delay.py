"""Actuation delay (paper §III-D): a step in the action reaches the actuators exactly the
episode's sampled delay later, checked substep by substep against an undelayed replay."""

from __future__ import annotations

import copy

import mujoco
import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config

NUM_ENVS = 16


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 5
    cfg.curriculum.enabled = False
    cfg.pushes.interval = (1e6, 1e6)  # no pushes: the replay below has none either
    cfg.pose_weights = {"supine": 1.0}  # lying robots: few episodes end within the test
    return RecoveryEnv(cfg)


def test_delay_is_sampled_per_episode_within_range(env):
    dt = env.cfg.physics_dt
    seconds = env.delay_steps * dt
    assert ((seconds >= 0.010 - 1e-9) & (seconds <= 0.040 + 1e-9)).all()
    assert len(np.unique(env.delay_steps)) >= 3  # per env, not one fixed value
    # MuJoCo's per-sim delay holds the command issued delay_steps substeps earlier
    for i in range(NUM_ENVS):
        delay = env.sims.get_model(i).actuator_delay
        assert np.all(np.floor(delay / dt + 1.0) == env.delay_steps[i])


def test_step_change_reaches_the_actuators_after_the_sampled_delay(env):
    """Replays each env with MuJoCo's delay off, switching ctrl by hand at substep d:
    the delayed env and the replay must agree to round-off over three control steps."""
    zero = torch.zeros(NUM_ENVS, env.num_actions)
    for _ in range(3):  # every actuator history now holds the zero action's targets
        env.step(zero)
    old = env.ctrl.copy()
    replays = []
    for i in range(NUM_ENVS):
        model = copy.copy(env.sims.get_model(i))
        model.actuator_delay[:] = 0.0
        replays.append((model, copy.copy(env.sims.get_data(i))))
    step_before = env.episode_length_buf.numpy().copy()
    action = torch.full((NUM_ENVS, env.num_actions), 0.5)
    dec = env.cfg.decimation
    checked = 0
    for control_step in range(3):
        env.step(action)
        new = env.ctrl.copy()
        for i, (model, data) in enumerate(replays):
            for k in range(dec):
                substep = control_step * dec + k
                data.ctrl[:] = new[i] if substep >= env.delay_steps[i] else old[i]
                mujoco.mj_step(model, data)
        ended = env.episode_length_buf.numpy() != step_before + control_step + 1
        for i, (_, data) in enumerate(replays):
            if ended[i]:
                continue
            np.testing.assert_allclose(env.qpos[i], data.qpos, atol=1e-9, err_msg=f"env {i}")
            checked += 1
    assert checked >= 2 * NUM_ENVS


def test_one_substep_off_is_detected(env):
    """The replay check is sensitive: switching one substep late diverges."""
    zero = torch.zeros(NUM_ENVS, env.num_actions)
    for _ in range(3):
        env.step(zero)
    old = env.ctrl.copy()
    i = int(np.argmin(env.delay_steps))
    model = copy.copy(env.sims.get_model(i))
    model.actuator_delay[:] = 0.0
    data = copy.copy(env.sims.get_data(i))
    env.step(torch.full((NUM_ENVS, env.num_actions), 0.5))
    for k in range(env.cfg.decimation):
        data.ctrl[:] = env.ctrl[i] if k >= env.delay_steps[i] + 1 else old[i]
        mujoco.mj_step(model, data)
    assert np.abs(env.qpos[i] - data.qpos).max() > 1e-6


def test_a_new_episode_starts_holding_its_initial_pose(env):
    """After a reset the delayed commands are the start configuration, not zeros."""
    ids = np.arange(NUM_ENVS)
    env._reset(ids)
    start = env.qpos[:, env.qadr]
    np.testing.assert_array_equal(env.ctrl, start)
    held = env.history[:, env._history_values]  # (N, 27, samples)
    np.testing.assert_array_equal(held, np.repeat(start[:, :, None], held.shape[2], 2))
