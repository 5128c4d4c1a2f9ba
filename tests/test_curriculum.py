"""The three-stage curriculum of the paper (§III-F) as a state machine (no simulator)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hybrid_recovery.envs.config import CurriculumConfig
from hybrid_recovery.envs.curriculum import Curriculum

WINDOW = 8


def make(**kwargs) -> Curriculum:
    return Curriculum(CurriculumConfig(window=WINDOW, **kwargs))


def earn(c: Curriculum) -> bool:
    """One window of successes: one advance."""
    return c.record(np.ones(WINDOW, dtype=bool))


def test_starts_in_exploration():
    c = make()
    assert (c.stage, c.level, c.difficulty) == (1, 0.0, 0.0)
    assert c.torque_scale == 10.0 and c.position_limit_factor == 1.0


def test_no_advance_before_the_window_is_full_or_below_the_success_rate():
    c = make()
    assert not c.record(np.ones(WINDOW - 1, dtype=bool))
    assert c.stage == 1
    c = make()
    outcomes = np.arange(WINDOW) < int(0.6 * WINDOW) - 1  # 4 of 8 < 0.6
    assert not c.record(outcomes)
    assert c.stage == 1
    # the window slides: more successes later do advance
    assert c.record(np.ones(WINDOW, dtype=bool))
    assert c.stage == 2


def test_advance_rule_through_all_stages():
    c = make()
    assert earn(c)
    assert (c.stage, c.level) == (2, pytest.approx(0.1))
    assert c.torque_scale == 10.0 and c.position_limit_factor == 1.0
    assert c.difficulty == pytest.approx(0.1)
    # stage 2: the level (difficulty) rises in steps of 0.1 to exactly 1
    for k in range(2, 11):
        assert earn(c)
        assert c.stage == 2 and c.level == pytest.approx(k / 10)
    assert c.level == 1.0 and c.difficulty == 1.0
    # then stage 3: annealing torque 10 → 1 and position factor 1 → 0.9 in the same steps
    torque, position = [], []
    for k in range(1, 11):
        assert earn(c)
        assert c.stage == 3 and c.level == pytest.approx(k / 10)
        assert c.difficulty == 1.0
        torque.append(c.torque_scale)
        position.append(c.position_limit_factor)
    np.testing.assert_allclose(torque, 10.0 - 0.9 * np.arange(1, 11))
    np.testing.assert_allclose(position, 1.0 - 0.01 * np.arange(1, 11))
    assert c.torque_scale == 1.0 and c.position_limit_factor == pytest.approx(0.9)
    # the end: no more advances, the final settings stay
    for _ in range(5):
        assert not earn(c)
    assert (c.stage, c.level, c.torque_scale) == (3, 1.0, 1.0)


def test_outcomes_are_forgotten_after_an_advance():
    c = make()
    earn(c)
    assert not c.record(np.ones(WINDOW - 1, dtype=bool))  # a new window must fill first
    assert c.record(np.ones(1, dtype=bool))


def test_disabled_starts_at_the_final_settings_and_never_moves():
    c = make(enabled=False)
    assert (c.stage, c.level, c.difficulty) == (3, 1.0, 1.0)
    assert c.torque_scale == 1.0 and c.position_limit_factor == pytest.approx(0.9)
    assert not earn(c)
    assert not c.record(np.zeros(WINDOW, dtype=bool))
    assert (c.stage, c.level) == (3, 1.0)


def test_state_dict_round_trip_through_json():
    c = make()
    for _ in range(3):
        earn(c)
    c.record(np.array([True, False, True]))
    restored = make()
    restored.load_state_dict(json.loads(json.dumps(c.state_dict())))
    assert restored.state_dict() == c.state_dict()
    assert (restored.stage, restored.level) == (2, pytest.approx(0.3))
    # the restored partial window completes with the same outcome in both
    rest = np.ones(WINDOW - 3, dtype=bool)
    assert c.record(rest) == restored.record(rest) is True
    assert restored.state_dict() == c.state_dict()


def test_a_resumed_run_at_the_end_of_annealing_stays_there():
    """A checkpoint whose level summed to 0.9999999999999999 must not restart stage 3."""
    c = make()
    c.load_state_dict({"stage": 3, "level": 0.9999999999999999, "outcomes": []})
    assert not earn(c)
    assert c.stage == 3 and c.torque_scale == pytest.approx(1.0)
