"""The hybrid supervisor is not worse than the policy it supervises on fixed pushes.

Pushes on the standing robot (the sweep's scenarios at 0.1 s, §IV) across directions,
forces up to 500 N and heights up to 0.6 m above the CoM, where the hybrid once lost
trials the policy alone won (the QP tried to step, then handed over a falling robot).
"""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.controllers import make
from hybrid_recovery.evaluation.scenario import SWEEP_DIRECTIONS, Scenario
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.policy import SHIPPED, resolve_policy

PUSHES = (  # force [N], direction, height above the CoM [m]
    (500.0, "front", 0.6),
    (400.0, "right", 0.6),
    (500.0, "right", 0.6),
    (450.0, "left", 0.0),
    (400.0, "back", 0.6),
    (300.0, "front", 0.0),
)


@pytest.mark.slow
def test_hybrid_wins_every_push_the_policy_wins():
    try:
        resolve_policy(SHIPPED)
    except FileNotFoundError as err:
        pytest.skip(str(err))
    learned, hybrid = make("learned"), make("hybrid")
    lost = []
    for force, direction, height in PUSHES:
        scenario = Scenario("standing", force, SWEEP_DIRECTIONS[direction], height,
                            duration=6.0, seed=0, noise=0.25)
        if run_trial(learned, scenario)["success"] and not run_trial(hybrid, scenario)["success"]:
            lost.append((force, direction, height))
    assert lost == []


def test_while_the_policy_acts_the_hybrid_is_the_policy():
    """Same servo model, step, delay and observation: until the QP first takes over, the
    hybrid's trajectory is the policy's own (round-off apart)."""
    try:
        resolve_policy(SHIPPED)
    except FileNotFoundError as err:
        pytest.skip(str(err))
    scenario = Scenario("standing", 300.0, SWEEP_DIRECTIONS["front"], 0.0, duration=0.6,
                        push_time=0.2, seed=0, noise=0.25)
    learned = run_trial(make("learned"), scenario, record=True)
    hybrid = run_trial(make("hybrid"), scenario, record=True)
    assert [kind for _, kind, _ in hybrid["controller_info"]["switches"]] == ["to_policy"]
    np.testing.assert_allclose(hybrid["trace"]["com"], learned["trace"]["com"], atol=1e-9)
