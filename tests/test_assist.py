"""Lifting assistance: force on the torso, annealing by success, saved state, resume."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.assist import Assist
from hybrid_recovery.envs.config import AssistConfig

WINDOW = 8


def test_off_by_default():
    cfg = default_config()
    assert cfg.assist.fraction == 0.0
    assert not Assist(cfg.assist, WINDOW, 0.6).active


def test_force_is_a_weight_fraction_gated_by_tilt():
    a = Assist(AssistConfig(fraction=0.5, max_tilt=np.deg2rad(60)), WINDOW, 0.6)
    mass = np.array([70.0, 70.0, 70.0])
    tilt = np.deg2rad([0.0, 50.0, 80.0])
    gravity_b = np.stack([np.sin(tilt), 0 * tilt, -np.cos(tilt)], 1)
    np.testing.assert_allclose(a.force_z(mass, gravity_b, 9.81), [343.35, 343.35, 0.0])


def test_anneals_by_success_then_switches_off_and_round_trips():
    a = Assist(AssistConfig(fraction=0.1, decay=0.5, floor=0.04), WINDOW, 0.6)
    assert not a.record(np.zeros(WINDOW, bool))  # failures: no decay
    assert a.fraction == 0.1
    assert a.record(np.ones(WINDOW, bool))
    assert a.fraction == pytest.approx(0.05)
    b = Assist(AssistConfig(fraction=0.1, decay=0.5, floor=0.04), WINDOW, 0.6)
    b.load_state_dict(a.state_dict())
    assert b.fraction == a.fraction
    assert a.record(np.ones(WINDOW, bool))  # 0.025 < floor: off
    assert a.fraction == 0.0 and not a.active
    assert not a.record(np.ones(WINDOW, bool))


@pytest.mark.parametrize("fraction", [0.0, 0.5])
def test_env_applies_the_force_to_the_torso(fraction):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.assist.fraction = 4, 1, fraction
    cfg.pose_weights = {p: float(p == "squatting") for p in cfg.pose_weights}
    env = RecoveryEnv(cfg)
    env.step(torch.zeros(4, env.num_actions))
    weight = env.randomizer.mass[:, 1:].sum(1) * GRAVITY
    upright = -env._state["gravity_b"][:, 2] > np.cos(cfg.assist.max_tilt)
    assert upright.any()
    env.step(torch.zeros(4, env.num_actions))
    np.testing.assert_allclose(env.xfrc[:, env.torso, 2][upright], fraction * weight[upright])
