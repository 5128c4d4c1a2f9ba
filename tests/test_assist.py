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


def test_the_pull_stops_at_its_height():
    a = Assist(AssistConfig(fraction=0.5, max_tilt=np.pi, max_height=0.85), WINDOW, 0.6)
    mass, lying = np.full(3, 70.0), np.tile([1.0, 0.0, 0.0], (3, 1))  # tilted 90°
    force = a.force_z(mass, lying, 9.81, height=np.array([0.3, 0.84, 0.9]))
    np.testing.assert_allclose(force, [343.35, 343.35, 0.0])


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


def test_assistance_by_start_pose():
    a = Assist(AssistConfig(fraction=0.5, poses=["supine", "sitting"]), WINDOW, 0.6)
    names = np.array(["standing", "supine", "sitting", "kneeling"])
    np.testing.assert_array_equal(a.assisted(names), [False, True, True, False])
    everyone = Assist(AssistConfig(fraction=0.5), WINDOW, 0.6)
    assert everyone.assisted(names).all()
    off = Assist(AssistConfig(fraction=0.0, poses=["supine"]), WINDOW, 0.6)
    assert not off.assisted(names).any()


def _pose_env(**assist):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads = 8, 1
    cfg.pose_weights = {p: float(p in ("standing", "supine")) for p in cfg.pose_weights}
    cfg.curriculum.window = WINDOW
    cfg.curriculum.stage1_poses = ["standing", "supine"]
    for key, value in assist.items():
        setattr(cfg.assist, key, value)
    return RecoveryEnv(cfg)


def test_a_pull_lifts_only_the_assisted_poses_in_any_attitude():
    env = _pose_env(fraction=0.5, max_tilt=np.pi, poses=["supine"])
    env.step(torch.zeros(8, env.num_actions))
    supine = np.asarray(env._pose_names)[env.start_pose] == "supine"
    assert supine.any() and (~supine).any()
    weight = env.randomizer.mass[:, 1:].sum(1) * GRAVITY
    lying = -env._state["gravity_b"][:, 2] < np.cos(np.deg2rad(60))
    assert (supine & lying).any()  # lying on its back, out of reach of a 60° gate
    env.step(torch.zeros(8, env.num_actions))
    np.testing.assert_allclose(env.xfrc[supine, env.torso, 2], 0.5 * weight[supine])
    pushes = env.pushes.force(env.upright_time, env.rng, env.curriculum.difficulty)
    assert np.allclose(env.xfrc[~supine, env.torso, 2], pushes[~supine, 2])


def test_assisted_episodes_anneal_the_pull_and_the_others_feed_the_curriculum():
    env = _pose_env(fraction=0.5, poses=["supine"])
    ids = np.arange(8)
    env.start_pose[:] = np.where(ids % 2, list(env._pose_names).index("supine"),
                                 list(env._pose_names).index("standing"))
    env.stood_up[:] = ids % 2 == 0  # the standing ones stood, the supine ones did not
    env._episode_log(ids, {name: np.zeros(8, bool) for name in ("timeout", "torso_contact",
                                                                "stuck_low", "nan")})
    assert list(env.assist._outcomes) == [False] * 4
    assert list(env.curriculum._outcomes) == [True] * 4
    everyone = _pose_env(fraction=0.5)  # no poses: every episode anneals, the curriculum waits
    everyone.stood_up[:] = True
    everyone._episode_log(ids, {name: np.zeros(8, bool) for name in ("timeout",
                                                                     "torso_contact",
                                                                     "stuck_low", "nan")})
    assert len(everyone.curriculum._outcomes) == 0 and everyone.assist.fraction < 0.5
