"""Recorded hybrid rises and the hand-over map: contents, starts and exact errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.evaluation.getup_record import record_rises
from hybrid_recovery.evaluation.handover_map import handover_map, handover_start
from hybrid_recovery.getup.ground_state import classify, read_ground_pose
from hybrid_recovery.policy import is_shipped
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.sim.initial_states import POSES


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_record_keeps_a_successful_rise_with_its_phases_and_contacts(tmp_path):
    out = record_rises("prone", 1, tmp_path / "rises.npz", duration=20.0, seed=1)
    assert out == {"attempted": 1, "kept": 1, "path": tmp_path / "rises.npz"}
    rec = np.load(tmp_path / "rises.npz")
    n = len(rec["time"])
    assert rec["qpos"].shape == (n, 34) and rec["qvel"].shape == (n, 33)
    assert rec["contacts"].shape == (n, len(rec["contact_bodies"]))
    assert (rec["episode"] == 0).all() and rec["seeds"].tolist() == [1]
    np.testing.assert_allclose(np.diff(rec["time"]), 0.02, atol=1e-9)
    phases = list(dict.fromkeys(rec["phase"].tolist()))
    # the QP may take over from the policy before the success criterion ends the trial
    assert phases in (["settle", "tuck/knee_chest", "policy"],
                      ["settle", "tuck/knee_chest", "policy", "qp"])
    # the moves' joint targets, exactly where the moves act, within the 0.9× ranges
    moving = np.array(["/" in p for p in rec["phase"]])
    lo, hi = SafetyLimits.from_model(load_torque_model()).q_ref_bounds(0.9)
    for key in ("target", "goal"):
        assert np.isfinite(rec[key][moving]).all() and np.isnan(rec[key][~moving]).all()
        assert ((rec[key][moving] >= lo - 1e-9) & (rec[key][moving] <= hi + 1e-9)).all()
    # the targets reach the phase's keyframe by its end (the hold)
    last = np.flatnonzero(moving)[-1]
    np.testing.assert_allclose(rec["target"][last], rec["goal"][last], atol=1e-9)
    bodies = rec["contact_bodies"].tolist()
    knee = bodies.index("left_knee_link")
    at_handover = rec["phase"].tolist().index("policy")
    assert rec["contacts"][at_handover - 1, knee]  # knee-chest: the knee is down
    # the last sample stands: the pelvis high, no body but the feet on the floor
    assert rec["qpos"][-1, 2] > 0.9
    down = {bodies[b] for b in np.flatnonzero(rec["contacts"][-1])}
    assert down <= {"left_ankle_roll_link", "right_ankle_roll_link"}
    assert rec["recovery_time"][0] <= rec["time"][-1]


def test_handover_start_settles_in_knee_chest():
    model = load_torque_model()
    data = handover_start(model, "knee_chest", np.random.default_rng(0), noise=0.5)
    mujoco.mj_forward(model, data)
    assert classify(read_ground_pose(model, data)) == "knee_chest"


def test_bad_input_messages(tmp_path):
    cases = [
        (lambda: record_rises("flying", 1, tmp_path / "x.npz"),
         f"unknown pose 'flying': choose one of {list(POSES)}"),
        (lambda: record_rises("prone", 0, tmp_path / "x.npz"), "episodes must be >= 1, got 0"),
        (lambda: handover_map(trials=0), "trials must be >= 1, got 0"),
        (lambda: handover_map(("hovering",)),
         "unknown hand-over state 'hovering': use one of ['hands_knees', 'knee_chest', "
         "'kneel_upright', 'side_sit']"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError) as err:
            call()
        assert str(err.value) == message
