"""A simulation that diverged never counts as a recovery: MuJoCo's instability warning (and
the reset it makes), a non-finite state or a runaway speed end the trial as ``diverged`` in
every runner, and the tables count it apart."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.controllers import make
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial, start_state
from hybrid_recovery.policy import is_shipped
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import default_qpos, load_mjmodel
from hybrid_recovery.sim.divergence import SimulationDiverged, clock_broken, divergence


@pytest.fixture(scope="module")
def model():
    return load_mjmodel(timestep=0.005)


def test_mujocos_reset_of_an_unstable_simulation_is_seen(model):
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    mujoco.mj_forward(model, data)
    assert divergence(data) is None
    data.xfrc_applied[model.body(constants.TORSO_BODY).id, :3] = (1e12, 0.0, 0.0)
    mujoco.mj_step(model, data)
    # MuJoCo reset the data: a finite, still robot at qpos0, the push gone, time restarted
    assert np.isfinite(data.qpos).all() and not data.xfrc_applied.any() and data.time < 0.01
    assert divergence(data) == ("MuJoCo: non-finite or huge acceleration (mjWARN_BADQACC) "
                                "at DOF 0")
    data = mujoco.MjData(model)
    data.ctrl[3] = np.nan
    mujoco.mj_step(model, data)
    assert divergence(data) == "MuJoCo: non-finite control (mjWARN_BADCTRL) at ACTUATOR 3"
    data = mujoco.MjData(model)
    data.qvel[7] = 2e3
    assert divergence(data) == "speed 2e+03 above 1000"
    data.qvel[7] = np.inf
    assert divergence(data) == "non-finite state"


def test_a_step_that_sends_the_clock_back_is_always_checked(model):
    from hybrid_recovery.sim.divergence import divergence_after_step

    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    data.qvel[7] = 2e3  # a runaway joint: found where all signs are checked
    before = data.time
    mujoco.mj_step(model, data)
    assert divergence_after_step(model, data, before, check_all=False) is None
    assert divergence_after_step(model, data, before, check_all=True).startswith("speed ")
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    data.time = 2.0
    data.xfrc_applied[model.body(constants.TORSO_BODY).id, :3] = (1e12, 0.0, 0.0)
    mujoco.mj_step(model, data)  # MuJoCo's reset: the clock restarts
    assert divergence_after_step(model, data, 2.0, check_all=False) == (
        "MuJoCo: non-finite or huge acceleration (mjWARN_BADQACC) at DOF 0 at t = 2.005 s")


def test_a_batch_clock_that_did_not_advance_marks_the_reset_simulations():
    before = np.array([1.0, 1.0, 0.0])
    after = np.array([1.02, 0.015, 0.02])  # the second was reset by MuJoCo in the call
    assert clock_broken(before, after, 0.02, 0.005).tolist() == [False, True, False]


@pytest.mark.parametrize(("force", "why", "when"), [
    # runs away in the push's first step, MuJoCo resets the data in its second
    (1e9, "MuJoCo: non-finite or huge acceleration (mjWARN_BADQACC)", " at t = 1.010 s"),
    # MuJoCo resets the data in the push's first step
    (1e12, "MuJoCo: non-finite or huge acceleration (mjWARN_BADQACC)", " at t = 1.005 s"),
    # a joint above 10³ rad/s, no MuJoCo warning: found before the next 50 Hz sample
    (1e6, "speed ", " at t = 1.020 s"),
])
def test_a_huge_push_ends_the_trial_diverged_never_a_success(force, why, when):
    row = run_trial(make("zero"), Scenario("standing", force, duration=4.0,
                                                      noise=0.25))
    assert row["success"] is False and row["recovery_time"] is None
    assert row["standing_at_end"] is False and row["stuck_low"] is False
    assert row["diverged"] is True
    assert row["divergence"].startswith(why) and row["divergence"].endswith(when)
    assert row["strategy"] == "diverged"


def test_a_non_finite_start_ends_the_trial_diverged_before_any_step():
    scenario = Scenario("standing", duration=3.0, noise=0.25)
    start = start_state(scenario, None, "default")
    start[10] = np.nan
    row = run_trial(make("zero"), scenario, start_qpos=start)
    assert row["success"] is False and row["standing_at_end"] is False
    assert row["diverged"] is True and row["divergence"] == "non-finite state at the start"


@pytest.mark.parametrize(("field", "value", "message"), [
    ("noise", float("nan"), "noise must be a finite number >= 0, got nan"),
    ("duration", float("inf"), "duration must be a finite number > 0, got inf"),
    ("force", float("nan"), "force must be a finite number, got nan"),
    ("height", float("inf"), "height must be a finite number, got inf"),
    ("seed", -5, "seed must be an integer >= 0, got -5"),
])
def test_a_scenario_a_trial_cannot_run_on_is_refused(field, value, message):
    with pytest.raises(ValueError) as err:
        Scenario("standing", **{field: value})
    assert str(err.value) == message


def test_a_trial_shorter_than_a_step_is_measured_not_an_index_error():
    row = run_trial(make("zero"), Scenario("standing", duration=1e-9, noise=0.25))
    assert row["success"] is False and row["diverged"] is False


def _rows():
    def row(pose, success, diverged=False, force=0.0, strategy="none"):
        return {"pose": pose, "force": force, "direction": 0.0, "success": success,
                "recovery_time": 1.0 if success else None, "fell": False,
                "stuck_low": False, "diverged": diverged,
                "strategy": "diverged" if diverged else strategy}

    return [row("standing", True), row("standing", False, diverged=True),
            row("standing", False, diverged=True), row("supine", True)]


def test_tables_count_diverged_trials_as_failures_and_apart():
    from hybrid_recovery.evaluation.report import comparison_table, summary_table

    lines = summary_table(_rows()).splitlines()
    assert lines[0].endswith("| falls | stuck low | diverged |")
    assert lines[2] == ("| standing | 3 | 33.3% | [6.1%, 79.2%] | 1.00 | 1.00 | 0 | 0.0% "
                        "| 2 |")
    assert lines[3].endswith("| 0 | 0.0% | 0 |")
    table = comparison_table({"zero": _rows()}).splitlines()
    assert table[0].endswith("| falls | diverged |")
    assert table[2].startswith("| zero | – | – | – | 4 | 50.0% |") and table[2].endswith(
        "| 0 | 2 |")


def test_the_report_says_how_many_trials_diverged(tmp_path):
    from hybrid_recovery.evaluation.report import strategy_table, write_report

    pushed = [dict(r, force=300.0) for r in _rows() if r["pose"] == "standing"]
    assert strategy_table(pushed).splitlines()[2] == "| 300 | 33% diverged |"
    text = write_report({"zero": _rows()}, tmp_path, "t", sweep_plots=False).read_text()
    assert ("2 of 4 trials diverged (the simulation became unstable; each row's "
            "`divergence` says why and when): they count as failures, never as "
            "recoveries.") in text


def test_the_demo_table_marks_a_diverged_trial_as_failed():
    from hybrid_recovery.demo.comparison import DEMO_SCENARIOS, _table

    rows = [dict(_rows()[1], scenario=name) for name in DEMO_SCENARIOS]
    assert _table({"PD hold (zero action)": rows}).splitlines()[2] == (
        "| push 100 N forward | ✗ (diverged) |")


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_a_handover_trial_from_a_nan_start_is_diverged_not_a_success():
    from hybrid_recovery.control.supervisor import HybridSupervisor
    from hybrid_recovery.control.torque_model import load_torque_model
    from hybrid_recovery.evaluation.handover_map import handover_start, map_table, policy_trial
    from hybrid_recovery.policy import resolve_policy

    torque_model = load_torque_model()
    data = handover_start(torque_model, "knee_chest", np.random.default_rng(0), noise=np.nan)
    supervisor = HybridSupervisor.from_onnx(resolve_policy("shipped") / "policy.onnx")
    found, why = policy_trial(torque_model, data, supervisor, duration=5.0)
    assert found is None
    assert why is not None and why.startswith("MuJoCo: ") and why.endswith(" before the policy")
    row = {"state": "knee_chest", "trials": 2, "successes": 0, "rate": 0.0, "ci": (0.0, 0.66),
           "mean_time": None, "diverged": 2}
    assert map_table([row]).splitlines()[2] == "| knee_chest | 2 | 0 % | 0–66 % | – | 2 |"


def test_the_handover_map_refuses_numbers_out_of_their_range():
    from hybrid_recovery.evaluation.handover_map import handover_map

    for kwargs, message in [
        ({"noise": float("nan")}, "noise must be a finite number from 0 to 5, got nan"),
        ({"noise": -1.0}, "noise must be a finite number from 0 to 5, got -1.0"),
        ({"duration": float("inf")}, "duration must be a finite number > 0, got inf"),
        ({"seed": -5}, "seed must be an integer >= 0, got -5"),
        ({"states": ("knee_chest", "side_sit", "knee_chest")},
         "hand-over state 'knee_chest' is named twice"),
    ]:
        with pytest.raises(ValueError) as err:
            handover_map(**kwargs)
        assert str(err.value) == message


def test_a_sim2sim_run_stops_where_it_diverged_and_is_not_upright(tmp_path):
    from hybrid_recovery.deploy.sim2sim import Sim2SimConfig, run_sim2sim
    from hybrid_recovery.training.stand_in import write_stand_in_policy

    policy = write_stand_in_policy(tmp_path / "policy", "zero")
    cfg = Sim2SimConfig(seconds=2.0, push_force=1e12, push_time=0.5, video=False)
    summary = run_sim2sim(f"onnx:{policy}", tmp_path / "out", cfg)
    assert summary["upright_at_end"] is False and summary["diverged"] is True
    assert summary["divergence"] == ("MuJoCo: non-finite or huge acceleration "
                                     "(mjWARN_BADQACC) at DOF 0 at t = 0.501 s")
    start = np.full(cfg_nq(), np.nan)
    with pytest.raises(SimulationDiverged) as err:
        run_sim2sim(f"onnx:{policy}", tmp_path / "nan",
                    Sim2SimConfig(start_qpos=start, video=False))
    assert str(err.value) == "the start state has diverged (non-finite state)"
    assert not (tmp_path / "nan").exists()


def cfg_nq() -> int:
    return load_mjmodel().nq


def test_a_pd_episode_that_diverged_is_not_standing():
    from hybrid_recovery.control.policy_controller import pd_torque
    from hybrid_recovery.control.rollout import Push, run_episode
    from hybrid_recovery.control.torque_model import load_torque_model
    from hybrid_recovery.robot.mjcf import joint_addresses

    torque_model = load_torque_model()
    qadr, dadr = joint_addresses(torque_model)

    class Hold:  # joint PD holding the default pose: stands, and stands again after a reset
        def reset(self, model, data) -> None:
            del model, data

        def __call__(self, model, data) -> np.ndarray:
            return pd_torque(constants.DEFAULT_JOINT_POS, data.qpos[qadr], data.qvel[dadr])

    result = run_episode(torque_model, Hold(), 1.0, push=Push(np.array([1e12, 0.0, 0.0]), 0.5))
    assert result.standing is False
    assert result.divergence is not None and result.divergence.startswith(
        "MuJoCo: non-finite or huge acceleration (mjWARN_BADQACC)")
    assert len(result.com) == 0.5 / torque_model.opt.timestep + 1


def test_the_qp_sweep_table_marks_a_diverged_push():
    from hybrid_recovery.bench.qp import sweep_table

    row = {"direction": "+x", "force": 300.0, "stepping": False, "standing": False,
           "strategy": "ankle", "steps": 0, "fell": False, "fallbacks": 0, "diverged": True}
    lines = sweep_table([row]).splitlines()
    assert lines[2] == "  +x      nan    DIV"
    assert lines[-1] == ("cells: strategy used (X = fell, with the last strategy tried; DIV = "
                         "the simulation diverged)")


def test_the_balance_report_refuses_to_go_on_past_a_divergence():
    from hybrid_recovery.demo.balance_report import balance_report

    with pytest.raises(SimulationDiverged) as err:
        balance_report(push_force=1e12)
    assert str(err.value) == ("the simulation diverged at t = 0.505 s (MuJoCo: non-finite or "
                              "huge acceleration (mjWARN_BADQACC) at DOF 0) under the 1e+12 N "
                              "push")


def test_a_move_whose_simulation_diverged_is_refused():
    from hybrid_recovery.control.torque_model import load_torque_model
    from hybrid_recovery.evaluation.move_margins import move_start
    from hybrid_recovery.getup.margins import margins_along
    from hybrid_recovery.getup.single_move import SingleMove

    torque_model = load_torque_model()
    data = move_start(torque_model, "tuck", 0)
    data.xfrc_applied[torque_model.body(constants.TORSO_BODY).id, :3] = (1e12, 0.0, 0.0)
    with pytest.raises(SimulationDiverged) as err:
        margins_along(torque_model, data, SingleMove("tuck"))
    assert str(err.value) == ("the simulation diverged at t = 0.002 s during the move (MuJoCo: "
                              "non-finite or huge acceleration (mjWARN_BADQACC) at DOF 0)")


def test_play_stops_where_the_environment_restarted_a_diverged_episode(tmp_path):
    from hybrid_recovery.evaluation.play import play

    out = tmp_path / "play.mp4"
    with pytest.raises(SimulationDiverged) as err:
        play(out, seconds=2.0, push=1e9, push_time=0.5, width=64, height=48)
    assert str(err.value) == (
        f"the simulation diverged at t = 0.52 s (unstable physics or a non-finite action) "
        f"and the environment restarted it; the video {out} stops there (13 frames)")
    assert out.stat().st_size > 0
