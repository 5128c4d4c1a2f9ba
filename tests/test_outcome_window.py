"""The success-rate window shared by the curriculum, the assistance and the bridges."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.envs.outcome_window import OutcomeWindow


def test_no_verdict_until_full_then_by_rate():
    w = OutcomeWindow(4)
    w.extend(np.array([True, True, True]))
    assert not w.full and w.verdict(0.5) == 0  # 3 of 3, but not yet 4 episodes
    w.extend([False])
    assert w.full and w.rate == 0.75 and w.verdict(0.75) == 1 and w.verdict(0.8) == 0
    assert w.verdict(0.9, retreat=0.8) == -1 and w.verdict(0.9, retreat=0.75) == 0


def test_oldest_outcomes_drop_out_and_clear_forgets():
    w = OutcomeWindow(3, [False, False, False])
    w.extend([True, True])
    assert list(w) == [False, True, True] and w.rate == pytest.approx(2 / 3)
    w.clear()
    assert len(w) == 0 and w.rate == 0.0 and w.state() == []


def test_a_window_needs_a_size():
    with pytest.raises(ValueError, match=r"^an outcome window needs size >= 1, got 0$"):
        OutcomeWindow(0)


def test_level_step_advances_retreats_and_never_below_level_zero():
    window = OutcomeWindow(4)
    assert window.level_step([True] * 3, level=2, advance=0.75, retreat=0.25) == 0
    assert window.level_step([True], level=2, advance=0.75, retreat=0.25) == 1
    assert len(window) == 0  # cleared on a change
    assert window.level_step([False] * 4, level=2, advance=0.75, retreat=0.25) == -1
    assert window.level_step([False] * 4, level=0, advance=0.75, retreat=0.25) == 0
    assert len(window) == 4  # no change at level 0: the window is kept
