"""The ``model`` and ``hybrid`` controllers on the ground, in the evaluation runner."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from conftest import REFERENCE_MJCF

import hybrid_recovery.controllers.hybrid as hybrid_module
import hybrid_recovery.controllers.model as model_module
from hybrid_recovery.control.supervisor import POLICY
from hybrid_recovery.controllers import HybridController, ModelController, make
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import eval_model, run_trial, start_state
from hybrid_recovery.getup.contact_map import maps_contacts
from hybrid_recovery.getup.move_executor import MoveConfig
from hybrid_recovery.getup.relapse import GetupConfig, com_height, lying_still
from hybrid_recovery.policy import SHIPPED, is_shipped, resolve_policy
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.initial_states import seat_single


def test_model_controller_moves_to_knee_chest_pushes_up_and_goes_on_to_the_squat():
    from hybrid_recovery.getup.push_up import on_hands_and_knees

    seen: list[tuple[float, bool]] = []
    controller = ModelController()
    row = run_trial(controller, Scenario("prone", duration=9.0, seed=0),
                    on_sample=lambda model, data, _: seen.append(
                        (float(data.time), on_hands_and_knees(model, data)[0])))
    info = row["controller_info"]
    assert info["ground_status"] == "arrived" and info["ground_state"] == "knee_chest"
    assert [m for _, _, m in info["moves"]] == ["tuck from prone", "in knee_chest"]
    # one push-up, started once knee-chest was reached, ended on hands and knees, inside
    # the effort limits throughout (the QP's torque rows, not a clip)
    [push_up] = info["push_ups"]
    assert push_up["start"] >= info["moves"][-1][0] and push_up["hands_and_knees"]
    assert 0.0 < push_up["worst_torque_ratio"] <= 1.0 + 1e-9
    # from the check on, hands and knees → squat (the to-squat still under way at 9 s),
    # its stages at the controller's pace (ToSquatConfig.time_scale)
    done = push_up["start"] + model_module.GROUND_PUSH_UP.duration + controller.push_up_settle
    [squat] = info["squats"]
    assert squat["start"] == pytest.approx(done, abs=0.01) and info["final_mode"] == "to_squat"
    starts = [t for t, _ in controller.to_squat.log]
    scale = model_module.GROUND_TO_SQUAT.time_scale
    assert len(starts) >= 3 and starts[0] == pytest.approx(squat["start"], abs=0.003)
    np.testing.assert_allclose(np.diff(starts), [stage.duration * scale for stage in
                                                 controller.to_squat.stages[:len(starts) - 1]],
                               atol=0.003)
    assert all(ok for t, ok in seen if done + 0.02 <= t <= squat["start"] + 0.5)
    assert any(not ok for t, ok in seen if t > squat["start"] + 1.0)  # a foot comes forward
    assert not row["success"] and not row["not_applicable"]
    assert row["peak_torque"] <= 300.0 + 1e-9
    controller.mode = model_module.QP  # as once the rise from the squat has begun
    assert controller.info()["moves"] == info["moves"]  # a chain that stands keeps its log


def test_model_controller_reaches_hands_and_knees_on_the_manufacturer_meshes():
    """The same moves and push-up on the mesh model, whose knees touch with the thigh
    meshes and hands with the wrist meshes (read as the named contacts where they touch)."""
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    controller = ModelController()
    row = run_trial(controller, Scenario("prone", duration=8.0, seed=0),
                    str(REFERENCE_MJCF), rotor_inertia=True)
    info = row["controller_info"]
    assert [m for _, _, m in info["moves"]] == ["tuck from prone", "in knee_chest"]
    [push_up] = info["push_ups"]
    [squat] = info["squats"]
    assert push_up["hands_and_knees"] and info["final_mode"] == "to_squat"
    done = push_up["start"] + model_module.GROUND_PUSH_UP.duration + controller.push_up_settle
    assert squat["start"] >= done - 0.01 and not row["success"]


def test_model_controller_re_plans_after_a_push_up_that_misses(monkeypatch):
    """A push-up that does not end on hands and knees hands the robot back to the moves,
    and after ``max_push_ups`` the moves hold it."""
    monkeypatch.setattr(model_module, "on_hands_and_knees", lambda model, data: (False, ""))
    row = run_trial(ModelController(max_push_ups=1),
                    Scenario("prone", duration=12.0, seed=0))
    info = row["controller_info"]
    assert [p["hands_and_knees"] for p in info["push_ups"]] == [False]
    assert [m for _, _, m in info["moves"]][:2] == ["tuck from prone", "in knee_chest"]
    assert info["final_mode"] == "moves" and info["ground_state"] == "knee_chest"


def test_model_controller_hands_moves_stuck_upright_to_the_qp(monkeypatch):
    """Moves that end where no move leads on but the QP applies (here: a standing start
    given to the moves, classified at once: ``upright``) hand the robot to the QP's
    balance, not to a joint-PD hold (under which this start falls)."""
    reset = ModelController.reset

    def moves_first(self, model, data):
        reset(self, model, data)
        self._start_moves(model, data)

    monkeypatch.setattr(ModelController, "reset", moves_first)
    controller = ModelController(MoveConfig(settle_time=0.0))
    row = run_trial(controller, Scenario("standing", duration=3.0, seed=0, noise=0.25))
    info = row["controller_info"]
    assert [m for _, _, m in info["moves"]] == ["in upright: no move from upright"]
    assert info["final_mode"] == "qp" and row["success"]


def test_model_controller_balances_with_the_qp_when_standing():
    row = run_trial(make("model"), Scenario("standing", duration=3.0, seed=0,
                                                       noise=0.25))
    assert row["success"] and row["controller_info"]["final_mode"] == "qp"
    stopped = run_trial(make("model"), Scenario("standing", duration=3.0, seed=0,
                                                           noise=0.25), stop_on_success=True)
    assert stopped["recovery_time"] == row["recovery_time"]


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_hybrid_with_the_moves_first_rises_from_prone_through_knee_chest():
    controller = HybridController(resolve_policy(SHIPPED),
                                        GetupConfig(policy_first=False))
    row = run_trial(controller, Scenario("prone", duration=20.0, seed=1), stop_on_success=True)
    info = row["controller_info"]
    assert row["success"], info
    (handover_time, state), = info["handovers"]
    assert state == "knee_chest"
    assert row["recovery_time"] > handover_time
    # the supervisor took over at the hand-over, in the policy (the QP does not apply)
    time, kind, message = info["switches"][0]
    assert kind == "to_policy" and time == pytest.approx(handover_time, abs=0.01)
    assert message.startswith("start: the policy stands first (QP not applicable")


def _settled(pose: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = eval_model(None, 0.005, False, "default")
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario(pose, seed=0), None, "default")
    seat_single(model, data)
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    return model, data


def test_lying_still_needs_a_low_com_still_joints_and_a_still_base():
    config = GetupConfig()
    model, data = _settled("prone")
    assert com_height(model, data) < config.ground_com_height
    assert lying_still(model, data, config)
    knee = model.joint("left_knee_joint").dofadr[0]
    data.qvel[knee] = 0.99 * config.still_joint_speed
    assert lying_still(model, data, config)
    data.qvel[knee] = -1.01 * config.still_joint_speed  # a policy still trying
    assert not lying_still(model, data, config)
    data.qvel[:] = 0.0
    data.qvel[1] = 1.01 * config.still_base_speed  # sliding or rolling
    assert not lying_still(model, data, config)
    model, data = _settled("standing")
    assert com_height(model, data) > config.ground_com_height
    assert not lying_still(model, data, config)


class _GaveUp:
    """Stands in for the supervised policy: holds the joints where they are at its reset,
    as a policy that has given up does (the relapse test sees only the CoM and the mode)."""

    def __init__(self) -> None:
        self.supervisor = SimpleNamespace(mode=POLICY)
        self.resets: list[float] = []

    def reset(self, model, data) -> None:
        self.resets.append(round(float(data.time), 3))
        self.q_ref = data.qpos[model.jnt_qposadr[1:1 + constants.NUM_JOINTS]].copy()

    def __call__(self, model, data):
        return self.q_ref

    def info(self) -> dict:
        return {"final_mode": POLICY}


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_the_policy_acts_first_on_the_ground_and_the_moves_come_when_it_lies_still():
    """From prone the policy acts first; lying still for ``relapse_time`` starts the moves
    (to knee-chest); lying still in knee-chest, a state no move starts from, starts them
    again (they arrive at once and hand over a second time)."""
    controller = make("hybrid")
    controller.supervised = stand_in = _GaveUp()
    config = controller.config
    model = eval_model(None, controller.physics_dt, False, "default")
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario("prone", seed=0), None, "default")
    seat_single(model, data)
    mujoco.mj_forward(model, data)
    controller.reset(model, data)
    assert controller.phase == POLICY and stand_in.resets == [0.0]
    while not controller.handovers:
        data.ctrl[:] = controller(model, data)
        mujoco.mj_step(model, data)
    first = data.time
    assert controller.handovers[0][1] == "knee_chest" and controller.relapses == 1
    [(start, _, message), *_] = controller.info()["moves"]
    # lying still from the first fraction of a second (the start settles), then the
    # relapse, the moves' settle and the first move
    assert (config.relapse_time + config.moves.settle_time <= start
            < config.relapse_time + 1.0 + config.moves.settle_time)
    assert "prone" in message
    while data.time < first + config.relapse_time + 1.0:
        data.ctrl[:] = controller(model, data)
        mujoco.mj_step(model, data)
    assert com_height(model, data) < config.ground_com_height
    assert controller.relapses == 2
    (t1, s1), (t2, s2) = controller.handovers
    assert s1 == s2 == "knee_chest"
    # relapse after relapse_time under the policy, then the moves' settle, then arrived
    assert t2 == pytest.approx(t1 + config.relapse_time + config.moves.settle_time, abs=0.011)
    assert stand_in.resets[1:] == [t1, t2]


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_the_hybrid_rises_from_sitting_with_the_policy_alone_as_fast_as_the_policy():
    """Where the policy rises, the hybrid is the policy: the same recovery, no moves."""
    scenario = Scenario("sitting", duration=12.0, seed=3)
    hybrid = run_trial(make("hybrid"), scenario, stop_on_success=True)
    learned = run_trial(make("learned"), scenario, stop_on_success=True)
    assert learned["success"] and hybrid["success"], hybrid["controller_info"]
    info = hybrid["controller_info"]
    assert info["handovers"] == [] and info["moves"] == [] and info["relapses"] == 0
    assert hybrid["recovery_time"] == pytest.approx(learned["recovery_time"], abs=0.05)


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_a_pause_of_the_rising_policy_is_not_taken_for_a_relapse(monkeypatch):
    """On the manufacturer's model the policy, pushed over from sitting, lies still for over
    a second before it rises (5.6 s); the hybrid, its moves forced on there, lets it rise
    instead of starting them, as the policy alone does."""
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    monkeypatch.setattr(hybrid_module, "maps_contacts", lambda model: True)
    scenario = Scenario("sitting", force=100.0, direction=np.pi, height=0.0, duration=12.0,
                        seed=1020123520, noise=0.25)
    kwargs = dict(model_path=REFERENCE_MJCF, rotor_inertia=True, stop_on_success=True)
    learned = run_trial(make("learned"), scenario, **kwargs)
    hybrid = run_trial(make("hybrid"), scenario, **kwargs)
    assert learned["success"] and learned["recovery_time"] > 4.0
    assert hybrid["success"], hybrid["controller_info"]
    assert hybrid["controller_info"]["moves"] == []


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_the_moves_run_only_on_a_model_with_the_named_contacts():
    """On the manufacturer's meshes (none of the project's named geoms) the hybrid never
    starts the moves: a policy that lies still keeps the ground (the policy pauses before
    some rises there, and the moves would hand over too late)."""
    assert maps_contacts(eval_model(None, 0.005, False, "default"))
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    controller = HybridController(resolve_policy(SHIPPED), GetupConfig(policy_first=False))
    model = eval_model(str(REFERENCE_MJCF), controller.physics_dt, False, "default")
    assert not maps_contacts(model)
    controller.supervised = _GaveUp()
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario("prone", seed=0), str(REFERENCE_MJCF), "default")
    seat_single(model, data)
    mujoco.mj_forward(model, data)
    controller.reset(model, data)
    assert controller.phase == POLICY
    while data.time < controller.config.relapse_time + 1.0:
        data.ctrl[:] = controller(model, data)
        mujoco.mj_step(model, data)
    assert com_height(model, data) < controller.config.ground_com_height
    info = controller.info()
    assert info["moves"] == [] and info["relapses"] == 0 and not info["moves_apply"]
