"""Ground moves executed in MuJoCo: prone → knee-chest ends in its contact state."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.controllers.model import ModelController
from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial, start_state
from hybrid_recovery.getup.feasibility import static_feasibility
from hybrid_recovery.getup.ground_state import GroundPose, classify, read_ground_pose
from hybrid_recovery.getup.keyframes import KEYFRAMES, mirror
from hybrid_recovery.getup.move_executor import GroundMoves, MoveConfig
from hybrid_recovery.getup.moves import MOVES
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.sim.initial_states import seat_single

KNEE_CHEST_CONTACTS = ("left_knee", "right_knee", "left_toes", "right_toes", "left_hand",
                       "right_hand", "head")


@pytest.fixture(scope="module")
def model():
    return load_torque_model()


def _start(model, pose: str, seed: int) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario(pose, seed=seed), None, "default")
    seat_single(model, data)
    mujoco.mj_forward(model, data)
    return data


def _run(model, data, moves: GroundMoves, until: float) -> tuple[float, float]:
    """Runs until the moves stop or ``until`` [s]; returns the peak |τ| [N·m] and the
    largest |q_ref − mid| / half-range of the targets sent."""
    lo, hi = SafetyLimits.from_model(model).q_ref_bounds(1.0)
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    peak, reach = 0.0, 0.0
    while data.time < until and moves.status == "moving":
        data.ctrl[:] = tau = moves(model, data)
        peak = max(peak, float(np.max(np.abs(tau) / constants.EFFORT_LIMITS)))
        reach = max(reach, float(np.max(np.abs(moves.q_ref - mid) / half)))
        mujoco.mj_step(model, data)
    return peak, reach


@pytest.mark.parametrize("seed, time_scale", [(0, 1.0), (1, 1.0), (0, 0.5)])
def test_prone_to_knee_chest_ends_in_its_contact_state(model, seed, time_scale):
    """At the keyframes' pace and at twice it (``MoveConfig.time_scale``, the ``model``
    controller's setting): the tuck's phase and hold take (duration + hold) × scale."""
    data = _start(model, "prone", seed)
    moves = GroundMoves(MoveConfig(time_scale=time_scale))
    moves.reset(model, data)
    peak, reach = _run(model, data, moves, until=10.0)
    assert moves.status == "arrived", [(e.kind, e.message) for e in moves.events]
    assert [e.message for e in moves.events] == ["tuck from prone", "in knee_chest"]
    [tuck] = MOVES["tuck"].phases
    start, end = (e.time for e in moves.events)
    assert start == pytest.approx(moves.config.settle_time, abs=0.003)
    assert end - start == pytest.approx((tuck.duration + tuck.hold) * time_scale, abs=0.003)
    pose = read_ground_pose(model, data)
    assert classify(pose) == "knee_chest"
    assert {"left_knee_link", "right_knee_link", "left_ankle_roll_link", "right_ankle_roll_link",
            "left_wrist_yaw_link", "right_wrist_yaw_link", "torso_link"} <= pose.touching
    assert "pelvis" not in pose.touching
    # settled: the state holds still and is statically feasible on these contacts at 1×
    mujoco.mj_subtreeVel(model, data)
    assert np.linalg.norm(data.subtree_linvel[1]) < 0.05
    check = static_feasibility(RobotModel(model), data.qpos.copy(), KNEE_CHEST_CONTACTS)
    assert check.feasible, check.reason
    assert peak <= 1.0 + 1e-12 and reach <= 0.9 + 1e-12


def test_a_retried_roll_runs_mirrored(model):
    moves = GroundMoves()
    data = _start(model, "supine", 0)
    moves.reset(model, data)
    np.testing.assert_allclose(mirror(mirror(KEYFRAMES["roll_twist"])), KEYFRAMES["roll_twist"])
    assert mirror(KEYFRAMES["roll_twist"])[12] == -KEYFRAMES["roll_twist"][12]
    moves._attempts["roll"] = 1  # as after a roll that missed
    data.time = 1.0
    moves(model, data)
    assert moves.move is not None and moves.move.name == "roll" and moves.mirrored


@pytest.mark.parametrize("chest, left, spine, pelvis, com, touching, state", [
    (0.0, 0.0, 1.0, 1.0, 0.95, {"left_ankle_roll_link"}, "upright"),
    (0.95, 0.0, 0.2, 0.15, 0.2, {"torso_link"}, "supine"),
    (-0.95, 0.0, 0.1, 0.15, 0.2, {"torso_link"}, "prone"),
    (-0.9, 0.0, -0.4, 0.4, 0.3, {"left_knee_link", "right_knee_link"}, "knee_chest"),
    (-0.9, 0.0, -0.4, 0.4, 0.3, {"left_knee_link"}, "other"),
    (0.3, 0.0, 0.9, 0.15, 0.4, {"pelvis"}, "sitting"),
    # sitting upright on the hip-pitch links, the pelvis clear (where a failed rise from
    # knee-chest ends under the policy): sitting, not "other"
    (0.04, 0.09, 0.99, 0.23, 0.34, {"left_hip_pitch_link", "right_hip_pitch_link",
                                    "left_ankle_roll_link"}, "sitting"),
    (0.3, 0.67, 0.68, 0.2, 0.34, {"left_hip_pitch_link", "right_elbow_link"}, "sitting"),
    (0.0, 0.9, 0.1, 0.15, 0.2, {"torso_link"}, "side"),
    (0.1, 0.0, 0.95, 0.6, 0.55, {"left_knee_link", "right_knee_link"}, "other"),
])
def test_ground_state_classification(chest, left, spine, pelvis, com, touching, state):
    assert classify(GroundPose(chest, left, spine, pelvis, com, frozenset(touching))) == state


def test_move_config_messages():
    with pytest.raises(ValueError) as err:
        MoveConfig(goal="flying")
    assert str(err.value) == ("unknown goal state 'flying': use one of ['upright', 'sitting', "
                              "'supine', 'prone', 'knee_chest', 'side', 'other']")
    with pytest.raises(ValueError) as err:
        MoveConfig(goal="upright")  # no model-based rise: a plan to stand is refused
    assert str(err.value) == ("no move ends in 'upright': the moves reach ['knee_chest', "
                              "'prone', 'supine']")
    with pytest.raises(ValueError) as err:
        MoveConfig(range_factor=1.2)
    assert str(err.value) == "MoveConfig.range_factor must be > 0 and <= 1, got 1.2"
    with pytest.raises(ValueError) as err:
        MoveConfig(time_scale=0.0)
    assert str(err.value) == "MoveConfig.time_scale must be > 0, got 0.0"
    with pytest.raises(ValueError) as err:
        MoveConfig(recheck_time=0.0)
    assert str(err.value) == "MoveConfig.recheck_time must be > 0, got 0.0"
    with pytest.raises(ValueError) as err:
        MoveConfig(prone_lean=-0.1)
    assert str(err.value) == "MoveConfig.prone_lean must be >= 0, got -0.1"
    assert MoveConfig(prone_lean=float("inf")).prone_lean == float("inf")


def test_a_falling_robot_is_classified_where_it_comes_to_rest():
    """Squatting seed 85 (the evaluation's start) falls forward out of the QP's rise: 0.5 s
    after the moves start it is still falling through a state with no move (``other``);
    they wait until the pelvis is slower than ``rest_speed`` and plan from where it lies
    (prone), where a classification at 0.5 s was stuck in ``other`` for the rest of the
    trial."""
    controller, samples = ModelController(), []

    def pelvis_speed(model, data, push):
        samples.append((float(data.time), float(np.linalg.norm(data.qvel[:3]))))

    run_trial(controller, Scenario("squatting", duration=3.0, seed=85), on_sample=pelvis_speed)
    moves = controller.moves
    [fell] = [e.time for e in controller.balance.events if e.kind == "rise_failed"]
    first = moves.events[0]
    assert first.kind == "move" and first.message.endswith(" from prone"), moves.events
    settled = fell + moves.config.settle_time
    assert first.time > settled + 0.2  # waited past the settle time
    assert max(v for t, v in samples if settled <= t < first.time) >= moves.config.rest_speed


def test_a_prone_torso_on_its_side_is_laid_flat_before_the_tuck():
    """Squatting seed 1000054 falls out of its rise onto its chest rolled ~40° toward its
    right side (|z| of the torso's left axis 0.5–0.7): the tuck from there ends in prone
    again, each retry alike. With ``prone_lean`` (the ``model`` controller's 0.4) the
    ``to_front`` move lays it flat first and the tuck then arrives in knee-chest."""
    lean = ModelController().moves.config.prone_lean
    assert lean == pytest.approx(0.4)
    controller = ModelController()
    run_trial(controller, Scenario("squatting", duration=11.0, seed=1000054))
    events = [(e.kind, e.message) for e in controller.moves.events]
    assert events == [("move", "to_front from prone"), ("move", "tuck from prone"),
                      ("arrived", "in knee_chest")], events
    flat = ModelController(MoveConfig(time_scale=0.5))  # prone_lean inf: straight to the tuck
    run_trial(flat, Scenario("squatting", duration=11.0, seed=1000054))
    assert [e.message for e in flat.moves.events][:2] == [
        "tuck from prone", "tuck ended in prone, not knee_chest"]


def test_moves_stuck_without_a_move_look_again_and_go_on():
    """Squatting seed 1000073 falls out of its rise and rests a moment bent over its wrists
    (``other``: no move), then topples onto its left side: the moves, stuck in ``other``,
    classify again every ``recheck_time`` at rest and go on from the side (where they
    were held in ``other`` for the rest of the trial)."""
    controller = ModelController()
    run_trial(controller, Scenario("squatting", duration=8.0, seed=1000073))
    events = [(e.kind, e.message) for e in controller.moves.events]
    assert events[:3] == [("stuck", "in other: no move from other"),
                          ("move", "to_front from side"), ("move", "tuck from prone")], events
    stuck, moved = controller.moves.events[0].time, controller.moves.events[1].time
    assert moved - stuck >= controller.moves.config.recheck_time - 1e-9


def test_the_first_classification_waits_at_most_max_settle(model):
    moves = GroundMoves(MoveConfig(rest_speed=1e-9, max_settle=1.2))
    data = _start(model, "prone", 0)
    moves.reset(model, data)
    _run(model, data, moves, until=3.0)
    assert moves.events[0].message == "tuck from prone"
    assert moves.events[0].time == pytest.approx(1.2, abs=0.003)
