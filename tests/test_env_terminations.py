"""Stuck-low termination and the paper's success criterion on synthetic signals."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.terminations import (
    SUCCESS_TILT,
    TERMINATIONS,
    StuckLow,
    success_step,
    upright,
)
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT

DT = 0.02
UPRIGHT_HEIGHT = 0.85


def run_stuck(heights: np.ndarray, duration: float = 2.0, rise: float = 0.02) -> np.ndarray:
    """Feeds a height sequence (T,) to StuckLow; returns the stuck flag per step (T,)."""
    stuck = StuckLow(1, duration, rise, DT)
    stuck.reset(np.array([0]), heights[:1])
    flags = [stuck.update(np.array([h]), DT, np.array([h < UPRIGHT_HEIGHT]))[0]
             for h in heights[1:]]
    return np.array([False, *flags])


def test_lying_still_for_two_seconds_is_stuck():
    rng = np.random.default_rng(0)
    heights = 0.2 + rng.uniform(-0.005, 0.005, 151)  # breathing noise below the 2 cm rise
    flags = run_stuck(heights)
    first = int(np.argmax(flags))
    assert flags.any() and first * DT == pytest.approx(2.0)
    assert not flags[:first].any()


def test_rising_steadily_is_never_stuck():
    heights = np.linspace(0.15, 0.8, 300)  # 6 s at 0.11 m/s
    assert not run_stuck(heights).any()


def test_slow_rise_that_gains_two_cm_every_two_seconds_is_not_stuck():
    heights = 0.2 + 0.0105 * np.arange(400) * DT  # 2.1 cm per 2 s
    assert not run_stuck(heights).any()


def test_falling_then_rising_is_not_stuck():
    """The fall counts as "no increase" (0.8 s), but the rise is measured from the bottom."""
    fall = np.linspace(0.9, 0.15, 40)  # 0.8 s fall
    lie = np.full(50, 0.15)  # 1 s on the ground: 1.8 s without a rise in all
    rise = np.linspace(0.15, 0.8, 150)  # stands up, +2 cm within 0.1 s
    assert not run_stuck(np.concatenate([fall, lie, rise])).any()


def test_a_fall_followed_by_lying_still_is_stuck():
    fall = np.linspace(0.9, 0.15, 40)
    assert run_stuck(np.concatenate([fall, np.full(100, 0.15)])).any()


def test_the_reference_follows_the_com_down():
    """After a fall the rise is measured from the lowest point, not the start height."""
    fall = np.linspace(0.7, 0.15, 20)
    crawl = 0.15 + 0.03 * (np.arange(200) // 80)  # +3 cm at 1.6 s and 3.2 s, below 0.7
    assert not run_stuck(np.concatenate([fall, crawl])).any()


def test_lying_still_after_a_failed_attempt_is_stuck_two_seconds_later():
    rise = 0.15 + 0.03 * np.arange(12)  # +3 cm every step: a rise at every step
    still = np.full(120, rise[-1])
    flags = run_stuck(np.concatenate([rise, still]))
    assert flags.any()
    assert (int(np.argmax(flags)) - (len(rise) - 1)) * DT == pytest.approx(2.0)


def test_upright_standing_still_is_never_stuck():
    assert not run_stuck(np.full(300, 0.9)).any()


def test_reset_clears_the_timer():
    stuck = StuckLow(2, 2.0, 0.02, DT)
    stuck.reset(np.array([0, 1]), np.array([0.2, 0.2]))
    for _ in range(99):
        stuck.update(np.array([0.2, 0.2]), DT, np.array([True, True]))
    stuck.reset(np.array([1]), np.array([0.2]))
    flags = stuck.update(np.array([0.2, 0.2]), DT, np.array([True, True]))
    np.testing.assert_array_equal(flags, [True, False])


def test_each_env_keeps_its_own_window():
    """Envs out of step (reset at different times) must not see each other's heights: a
    robot lying still is stuck even while another one lies lower or rises."""
    stuck = StuckLow(3, 2.0, 0.02, DT)
    stuck.reset(np.arange(3), np.array([0.3, 0.1, 0.1]))
    for k in range(150):
        if k == 30:
            stuck.reset(np.array([2]), np.array([0.1]))  # out of step from now on
        flags = stuck.update(np.array([0.3, 0.1, 0.1 + 0.01 * k]), DT, np.ones(3, bool))
    np.testing.assert_array_equal(flags, [True, True, False])


# ---------------------------------------------------------------- success (paper §IV-A3)
def gravity_at_tilt(deg: float) -> np.ndarray:
    t = np.deg2rad(deg)
    return np.array([[np.sin(t), 0.0, -np.cos(t)]])


@pytest.mark.parametrize("height,vel,tilt,ok", [
    (0.90, 0.0, 0.0, True),
    (0.90, 0.09, 60.0, True),
    (0.90, 0.0, 80.0, False),   # tilted beyond 72°
    (0.84, 0.0, 0.0, False),    # too low
    (0.90, -0.15, 0.0, False),  # still moving vertically
])
def test_upright(height, vel, tilt, ok):
    assert upright(np.array([height]), np.array([vel]), gravity_at_tilt(tilt))[0] == ok


def test_success_constants_are_the_papers():
    assert UPRIGHT_COM_HEIGHT == 0.85 and np.rad2deg(SUCCESS_TILT) == pytest.approx(72.0)
    assert TERMINATIONS == ("timeout", "torso_contact", "stuck_low", "nan")


def _upright_time(pattern: list[bool]) -> np.ndarray:
    t, out = np.zeros(1), []
    for ok in pattern:
        s = {"height": np.array([0.9 if ok else 0.6]), "height_vel": np.zeros(1),
             "gravity_b": gravity_at_tilt(0.0)}
        t = success_step(t, s, DT)
        out.append(t[0])
    return np.array(out)


def test_one_second_upright_succeeds():
    times = _upright_time([True] * 50)
    assert times[-1] >= 1.0 and times[-2] < 1.0


def test_half_second_bounces_never_succeed():
    bounce = ([True] * 25 + [False]) * 6
    times = _upright_time(bounce)
    assert times.max() == pytest.approx(0.5) and (times < 1.0).all()


def test_wiggling_on_the_ground_does_not_postpone_stuck():
    t = np.arange(300) * DT
    heights = 0.3 + 0.03 * np.sin(2 * np.pi * 1.0 * t)  # ±3 cm at 1 Hz, no net rise
    flags = run_stuck(heights)
    assert flags.any() and int(np.argmax(flags)) * DT <= 3.0


def test_stood_up_drops_only_the_stillness_clause():
    """Up and upright while bobbing at 0.15 m/s: stood up after 1 s, never a success."""
    s = {"height": np.array([0.9]), "height_vel": np.array([0.15]),
         "gravity_b": gravity_at_tilt(10.0)}
    full, up = np.zeros(1), np.zeros(1)
    for _ in range(60):
        full, up = success_step(full, s, DT), success_step(up, s, DT, still=False)
    assert full[0] == 0.0 and up[0] >= 1.0
    tilted = dict(s, gravity_b=gravity_at_tilt(80.0))
    assert not upright(tilted["height"], tilted["height_vel"], tilted["gravity_b"], still=False)


def test_unknown_advance_on_is_refused():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads = 2, 1
    cfg.curriculum.advance_on = "up"
    with pytest.raises(ValueError, match="advance_on"):
        RecoveryEnv(cfg)


@pytest.mark.parametrize("key", ["curriculum.advance_poses", "curriculum.stage1_poses",
                                 "pose_weights", "assist.poses"])
def test_unknown_poses_are_refused(key):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads = 2, 1
    if key == "pose_weights":
        cfg.pose_weights = {"standing": 1.0, "crawling": 1.0}
    else:
        group, name = key.split(".")
        setattr(getattr(cfg, group), name, ["standing", "crawling"])
    with pytest.raises(ValueError, match=rf"{key} has unknown poses \['crawling'\]"):
        RecoveryEnv(cfg)


@pytest.mark.parametrize("gated", [None, ("standing",)])
def test_only_episodes_from_the_advance_poses_count_for_the_curriculum(gated):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.episode_length_s = 4, 1, 0.2
    cfg.pose_weights = {"supine": 1.0}
    cfg.curriculum.stage1_poses = ("supine",)
    cfg.curriculum.advance_poses = gated
    cfg.curriculum.window = 10_000  # never full: the outcomes stay to be counted
    env = RecoveryEnv(cfg)
    ended = 0
    for _ in range(25):
        _, _, done, _ = env.step(torch.zeros(4, env.num_actions))
        ended += int(done.sum())
    assert ended >= 4
    assert len(env.curriculum._outcomes) == (ended if gated is None else 0)


def test_episodes_started_along_a_rise_or_bridge_do_not_count_for_the_curriculum():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.episode_length_s = 4, 1, 0.2
    cfg.pose_weights = {"supine": 1.0}
    cfg.curriculum.stage1_poses = ("supine",)
    cfg.curriculum.advance_poses = None  # every pose counts, from its own starts
    cfg.curriculum.window = 10_000
    env = RecoveryEnv(cfg)
    reset = env._reset

    def along_a_rise(ids):  # as RiseStarts' and the bridges' starts mark them
        reset(ids)
        env.start_level[ids] = 2

    env._reset = along_a_rise
    env.start_level[:] = 2
    ended = 0
    for _ in range(25):
        _, _, done, _ = env.step(torch.zeros(4, env.num_actions))
        ended += int(done.sum())
    assert ended >= 4 and len(env.curriculum._outcomes) == 0
