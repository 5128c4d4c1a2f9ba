"""The ``model`` and ``hybrid`` controllers on the ground, in the evaluation runner."""

from __future__ import annotations

import pytest

from hybrid_recovery.evaluation.controllers import make_controller
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.policy import is_shipped


def test_model_controller_moves_to_knee_chest_and_stops_there():
    row = run_trial(make_controller("model"), Scenario("prone", duration=8.0, seed=0))
    info = row["controller_info"]
    assert info["final_mode"] == "moves" and info["ground_status"] == "arrived"
    assert info["ground_state"] == "knee_chest"
    assert [m for _, _, m in info["moves"]] == ["tuck from prone", "in knee_chest"]
    # no model-based rise from knee-chest: it does not stand, and it says so by not succeeding
    assert not row["success"] and not row["not_applicable"]
    assert row["peak_torque"] <= 300.0 + 1e-9


def test_model_controller_balances_with_the_qp_when_standing():
    row = run_trial(make_controller("model"), Scenario("standing", duration=3.0, seed=0,
                                                       noise=0.25))
    assert row["success"] and row["controller_info"]["final_mode"] == "qp"
    stopped = run_trial(make_controller("model"), Scenario("standing", duration=3.0, seed=0,
                                                           noise=0.25), stop_on_success=True)
    assert stopped["recovery_time"] == row["recovery_time"]


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_hybrid_rises_from_prone_through_knee_chest():
    row = run_trial(make_controller("hybrid"), Scenario("prone", duration=20.0, seed=1),
                    stop_on_success=True)
    info = row["controller_info"]
    assert row["success"], info
    (handover_time, state), = info["handovers"]
    assert state == "knee_chest"
    assert row["recovery_time"] > handover_time
    # the supervisor took over at the hand-over, in the policy (the QP does not apply)
    time, kind, message = info["switches"][0]
    assert kind == "to_policy" and time == pytest.approx(handover_time, abs=0.01)
    assert message.startswith("start: the policy stands first (QP not applicable")
