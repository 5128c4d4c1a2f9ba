"""Lifting assistance: force on the torso, annealing by success, saved state, resume."""

from __future__ import annotations

import copy

import mujoco
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


@pytest.mark.parametrize("window", [None, 4.0, float("inf")])
def test_assisted_episodes_can_have_their_own_stuck_low_window(window):
    env = _pose_env(fraction=0.5, poses=["supine"], stuck_time=window)
    helped = np.arange(8) % 2 == 1
    env.stuck.reset(np.arange(8), np.full(8, 0.3))
    if env.stuck_assisted is not None:
        env.stuck_assisted.reset(np.arange(8), np.full(8, 0.3))
    first = np.full(8, np.inf)
    for step in range(1, 301):  # 6 s lying still at h_c = 0.3 m
        stuck = env._stuck_low(np.full(8, 0.3), helped)
        first[stuck & np.isinf(first)] = step * env.dt
    np.testing.assert_allclose(first[~helped], 2.0)  # everyone else: the env's 2 s
    expected = {None: 2.0, 4.0: 4.0, float("inf"): np.inf}[window]
    np.testing.assert_allclose(first[helped], expected)
    env.step(torch.zeros(8, env.num_actions))  # the step takes the same path


def test_an_unknown_mode_is_refused():
    with pytest.raises(ValueError, match="assist.mode"):
        Assist(AssistConfig(fraction=0.5, mode="crane"), WINDOW, 0.6)


def test_gravity_mode_cancels_that_fraction_of_gravity_on_every_body():
    """Σ_b J_bᵀ F_b of the lift equals f times MuJoCo's own gravity term g(q) (qfrc_bias at
    q̇ = 0, with that env's randomised masses); unassisted envs carry no force but the
    torso's push."""
    f = 0.4
    env = _pose_env(fraction=f, max_tilt=np.pi, poses=["supine"], mode="gravity")
    for _ in range(3):
        env.step(torch.zeros(8, env.num_actions))
    supine = np.asarray(env._pose_names)[env.start_pose] == "supine"
    assert supine.any() and (~supine).any()
    others = np.delete(env.xfrc[~supine], env.torso, axis=1)
    assert (others == 0.0).all()
    model = copy.copy(env.model)  # its masses set per env below
    data = mujoco.MjData(model)
    for i in np.flatnonzero(supine):
        model.body_mass[:] = env.randomizer.mass[i]
        data.qpos[:], data.qvel[:] = env.qpos[i], 0.0
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(env.xfrc[i, :, 2], f * GRAVITY * env.randomizer.mass[i])
        qfrc = np.zeros(model.nv)
        for body in range(1, model.nbody):
            mujoco.mj_applyFT(model, data, env.xfrc[i, body, :3], env.xfrc[i, body, 3:],
                              data.xipos[body], body, qfrc)
        np.testing.assert_allclose(qfrc, f * data.qfrc_bias, atol=1e-6)
