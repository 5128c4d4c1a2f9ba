"""Evaluation: success criterion, strategy labels, confidence intervals, protocols, report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hybrid_recovery.evaluation import run_protocol
from hybrid_recovery.evaluation.runner import completed_keys, load_results
from hybrid_recovery.evaluation.scenario import (
    SWEEP_DIRECTIONS,
    SWEEP_POSES,
    Scenario,
    pushes_protocol,
    sweep_protocol,
)
from hybrid_recovery.evaluation.strategy import CONTACT_BODIES, label_strategy
from hybrid_recovery.evaluation.success import recovery_time, stuck_low, wilson_interval

DT = 0.02


def _upright(n):
    return np.tile([0.0, 0.0, -1.0], (n, 1))


def _tilted(n, degrees):
    a = np.deg2rad(degrees)
    return np.tile([np.sin(a), 0.0, -np.cos(a)], (n, 1))


def test_steady_stand_is_a_success():
    t = np.arange(150) * DT
    h = np.full(150, 0.92)
    assert recovery_time(t, h, np.zeros(150), _upright(150)) == pytest.approx(0.0)


def test_bounce_above_threshold_for_half_a_second_fails():
    t = np.arange(300) * DT
    h = np.full(300, 0.5)
    h[100:125] = 0.9  # 0.5 s above 0.85 m
    assert recovery_time(t, h, np.zeros(300), _upright(300)) is None


def test_tilt_beyond_72_degrees_fails_and_within_succeeds():
    t = np.arange(100) * DT
    h = np.full(100, 0.9)
    assert recovery_time(t, h, np.zeros(100), _tilted(100, 80)) is None
    assert recovery_time(t, h, np.zeros(100), _tilted(100, 60)) is not None


def test_vertical_speed_must_be_small():
    t = np.arange(100) * DT
    assert recovery_time(t, np.full(100, 0.9), np.full(100, 0.2), _upright(100)) is None


def test_recovery_time_counts_from_start_and_after_the_push():
    t = np.arange(400) * DT
    h = np.full(400, 0.9)
    h[60:200] = 0.4  # down between 1.2 s and 4.0 s
    vel = np.zeros(400)
    assert recovery_time(t, h, vel, _upright(400)) == pytest.approx(0.0)
    assert recovery_time(t, h, vel, _upright(400), start=1.1) == pytest.approx(4.0 - 1.1)


def test_stuck_low_matches_the_training_termination():
    lying = np.full(150, 0.3)  # 3 s without a rise
    assert stuck_low(lying[:100], DT) is False  # 2 s: the window is not yet full
    assert stuck_low(lying, DT) is True
    rising = 0.3 + 0.02 * np.arange(150) * DT  # 4 cm per 2 s
    assert stuck_low(rising, DT) is False
    wiggling = 0.3 + 0.03 * np.sin(np.arange(300) * DT * 2 * np.pi * 3)  # troughs repeat
    assert stuck_low(wiggling, DT) is True
    assert stuck_low(np.full(300, 0.92), DT) is False  # standing is never stuck


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-3)
    lo, hi = wilson_interval(10, 10)
    assert lo == pytest.approx(0.7225, abs=1e-3) and hi == 1.0
    lo, hi = wilson_interval(934, 1000)
    assert lo == pytest.approx(0.9170, abs=1e-3) and hi == pytest.approx(0.9481, abs=1e-3)


def test_wilson_interval_always_contains_the_rate():
    """Error bars (rate − lo, hi − rate) are never negative; at 60 of 60, rounding once
    gave hi = 1 − 1e-16 and broke the sweep report's bar chart."""
    for n in range(1, 501):
        for k in (0, n // 3, n):
            lo, hi = wilson_interval(k, n)
            assert lo <= k / n <= hi, (k, n)


def _trace(n=200, push=1.0):
    t = np.arange(n) * DT
    contacts = np.zeros((n, len(CONTACT_BODIES)), dtype=bool)
    contacts[:, :2] = True  # both feet down
    return {"t": t, "contacts": contacts, "ang_mom": np.zeros((n, 3)),
            "hip": np.zeros((n, 2))}, int(push / DT)


def test_strategy_labels_on_constructed_trajectories():
    trace, k = _trace()
    assert label_strategy(trace, None) == "none"
    assert label_strategy(trace, 1.0) == "ankle"
    trace["ang_mom"][k + 5, 1] = 5.0
    assert label_strategy(trace, 1.0) == "hip"
    trace, k = _trace()
    trace["hip"][k + 5:, 0] = 0.3
    assert label_strategy(trace, 1.0) == "hip"
    trace, k = _trace()
    trace["contacts"][k + 10:k + 20, 0] = False  # left foot in the air 0.2 s, then down
    assert label_strategy(trace, 1.0) == "stepping"
    trace["contacts"][k + 30, 2] = True  # a hand touches down
    assert label_strategy(trace, 1.0) == "multi_contact"
    trace, k = _trace()
    trace["contacts"][k + 10:k + 11, 1] = False  # a 20 ms flicker is no step
    assert label_strategy(trace, 1.0) == "ankle"


def test_protocol_grids():
    sweep = sweep_protocol(1)
    assert len(sweep) == 5 * 11 * 4 * 5
    assert len({s.key for s in sweep}) == len(sweep)
    assert len(pushes_protocol(2)) == 10 * 4 * 2


@pytest.mark.parametrize("protocol", [lambda: sweep_protocol(2, seed=2),
                                      lambda: pushes_protocol(3, seed=2)])
def test_push_trials_start_apart_except_mirrored_left_right_twins(protocol):
    """Independent trials (a grid of one start would make its intervals too narrow); a
    right push shares its left twin's seed (and starts from its mirror image)."""
    trials = protocol()
    lateral = [s for s in trials if abs(np.sin(s.direction)) > 0.5]
    assert len({s.seed for s in trials}) == len(trials) - len(lateral) // 2
    by_key = {(s.pose, s.force, round(s.direction, 6), s.height, s.seed) for s in trials}
    assert all((s.pose, s.force, round(-s.direction, 6), s.height, s.seed) in by_key
               for s in lateral)
    other_seed = {s.seed for s in (sweep_protocol(2, seed=3) if len(trials) > 200
                                   else pushes_protocol(3, seed=3))}
    assert not other_seed & {s.seed for s in trials}


def test_a_cell_draws_the_same_starts_whatever_runs_beside_it():
    cell = sweep_protocol(3, seed=2, poses=("sitting",), forces=(200.0,),
                          directions=("right",), heights=(0.2,))
    full = [s for s in sweep_protocol(3, seed=2) if s.pose == "sitting" and s.force == 200.0
            and s.direction == cell[0].direction and s.height == 0.2]
    assert [s.seed for s in cell] == [s.seed for s in full] and len(cell) == 3


def test_eval_poses_restricts_the_poses_protocol_too():
    from argparse import Namespace

    from hybrid_recovery.cli.cmd_eval import _scenarios
    from hybrid_recovery.cli.errors import UsageError

    def args(protocol, poses):
        return Namespace(protocol=protocol, trials=40, seed=2, duration=None, poses=poses)

    picked = _scenarios(args("poses", ["squatting", "kneeling"]))
    assert len(picked) == 40 and {s.pose for s in picked} == {"squatting", "kneeling"}
    assert {s.pose for s in _scenarios(args("poses", None))} == set(SWEEP_POSES)
    assert {s.pose for s in _scenarios(args("sweep", ["kneeling"]))} == {"kneeling"}
    with pytest.raises(ValueError, match="unknown pose 'flying'"):
        _scenarios(args("poses", ["squatting", "flying"]))
    with pytest.raises(UsageError, match="pushes start from standing"):
        _scenarios(args("pushes", ["kneeling"]))


def test_tiny_sweep_runs_resumes_and_reports(tmp_path):
    from hybrid_recovery.evaluation.report import write_report

    scenarios = sweep_protocol(1, poses=("standing", "kneeling"), forces=(0.0, 200.0),
                               directions=("front", "left"), heights=(0.0, 0.6),
                               duration=2.0)
    results = tmp_path / "results.jsonl"
    first = run_protocol(scenarios[:5], "zero", results, workers=1, progress=False)
    assert len(first) == 5
    with results.open("a") as f:
        f.write('{"key": "torn')  # a run killed mid-write
    rows = run_protocol(scenarios, "zero", results, workers=2, progress=False)
    assert len(rows) == len(scenarios) == 16
    assert completed_keys(results) >= {s.key for s in scenarios}
    assert json.loads(results.read_text().splitlines()[0])["key"] == "__header__"
    report = write_report({"zero": rows}, tmp_path / "report", "tiny sweep")
    text = report.read_text()
    for panel in ("A_no_push", "BC_force", "D_time", "E_direction", "F_height"):
        assert panel in text and any(tmp_path.joinpath("report").glob(f"*{panel}.png"))
    assert len(load_results(results)) == 17
    assert all(isinstance(r["stuck_low"], bool) for r in rows) and "stuck low" in text


def test_a_results_file_is_resumed_only_by_the_run_that_wrote_it(tmp_path):
    scenarios = [Scenario("standing", duration=0.1, noise=0.0)]
    results = tmp_path / "results.jsonl"
    header = {"protocol": "poses", "trials": 1, "seed": 2, "poses": None}
    run_protocol(scenarios, "zero", results, workers=1, header=header, progress=False)
    before = results.read_text()
    # trial keys name the scenario only: without the check these would be "done" already
    with pytest.raises(ValueError, match="another run \\(controller: 'zero' there, 'learned'"):
        run_protocol(scenarios, "learned", results, workers=1, header=header, progress=False)
    with pytest.raises(ValueError, match="another run \\(protocol"):
        run_protocol(scenarios, "zero", results, workers=1,
                     header={**header, "protocol": "sweep"}, progress=False)
    with pytest.raises(ValueError, match="another run \\(poses"):
        run_protocol(scenarios, "zero", results, workers=1,
                     header={**header, "poses": ["standing"]}, progress=False)
    assert results.read_text() == before
    rows = run_protocol(scenarios, "zero", results, workers=1, header=header, progress=False)
    assert len(rows) == 1 and results.read_text() == before
    stray = tmp_path / "stray.jsonl"
    stray.write_text('{"key": "standing|0"}\n')
    with pytest.raises(ValueError, match="no header"):
        run_protocol(scenarios, "zero", stray, workers=1, progress=False)


def test_capture_point_figure_from_a_recorded_push(tmp_path):
    from hybrid_recovery.controllers import make
    from hybrid_recovery.evaluation.report import capture_point_figure
    from hybrid_recovery.evaluation.trial import run_trial

    row = run_trial(make("zero"), Scenario("standing", 150.0, duration=2.0,
                                                      noise=0.0), record=True)
    trace = row["trace"]
    assert trace["cp"].shape == (100, 2) and np.isfinite(trace["feet_xy"]).any()
    capture_point_figure(trace, 1.0, tmp_path / "cp.png")
    assert (tmp_path / "cp.png").stat().st_size > 10_000


def test_bad_controller_and_pose_are_refused():
    from hybrid_recovery.controllers import make
    from hybrid_recovery.evaluation.trial import run_trial

    with pytest.raises(ValueError, match="unknown controller 'nope'"):
        make("nope")
    with pytest.raises(ValueError, match="unknown pose 'flying'"):
        run_trial(make("zero"), Scenario("flying", duration=0.1))


def test_demo_runs_and_writes_a_report(tmp_path):
    """Three controllers side by side (the model-based ground moves, ~2 min of QPs, are
    tested in ``test_getup_controllers.py``); by default every one the machine has."""
    from hybrid_recovery.demo.comparison import available_controllers, run_demo

    report = run_demo(tmp_path, video=False, controllers=["zero", "qp", "learned"])
    text = report.read_text()
    assert "push 200 N forward" in text and "stand up from supine" in text
    for label in ("PD hold (zero action)", "QP baseline", "learned policy"):
        assert label in text
    specs, notes = available_controllers()
    assert specs == ["zero", "qp", "model", "learned", "hybrid"] and notes == []


def test_results_record_the_policy_and_the_report_compares_budgets(tmp_path):
    from hybrid_recovery.evaluation.report import comparison_table, write_report
    from hybrid_recovery.evaluation.runner import header_provenance
    from hybrid_recovery.policy.shipped import resolve_policy

    shipped_dir = resolve_policy("shipped")
    shipped = json.loads((shipped_dir / "policy.json").read_text())
    results = tmp_path / "learned.jsonl"
    run_protocol([Scenario("standing", duration=0.2, noise=0.0)], "learned", results,
                 workers=1, progress=False)
    header = json.loads(results.read_text().splitlines()[0])
    assert header["policy"] == shipped["provenance"]
    assert header_provenance(header) == shipped["provenance"]
    # results written before the header held it: read from the policy.json beside the ONNX
    del header["policy"]
    header["controller"] = f"onnx:{shipped_dir / 'policy.onnx'}"
    assert header_provenance(header) == shipped["provenance"]
    assert header_provenance({"controller": "zero"}) is None

    def rows(stuck, n=10):
        return [{"pose": "supine", "force": 0.0, "success": False, "recovery_time": None,
                 "stuck_low": k < stuck, "fell": True} for k in range(n)]

    runs = {"full a": rows(6), "full b": rows(3), "reduced a": rows(10), "zero": rows(0, 4)}
    provenance = {"full a": {"variant": "full", "iteration": 800, "env_steps": 19_685_376},
                  "full b": {"variant": "full", "iteration": 1350, "env_steps": 33_202_176},
                  "reduced a": {"variant": "reduced", "iteration": 800,
                                "env_steps": 19_685_376}}
    table = comparison_table(runs, provenance).splitlines()
    lo, hi = wilson_interval(6, 10)
    none_hi = wilson_interval(0, 10)[1]
    assert table[2] == (f"| full a | full | 800 | 19.7 | 10 | 0.0% | [0.0%, {none_hi:.1%}] | "
                        f"60.0% | [{lo:.1%}, {hi:.1%}] | 10 | 0 |")
    assert table[4].split(" | ")[7] == "100.0%" and table[5].startswith("| zero | – | – | – | 4 |")
    report = write_report(runs, tmp_path / "report", "budgets", provenance=provenance)
    assert "## Comparison" in report.read_text()
    assert (tmp_path / "report" / "stuck_low_vs_budget.png").stat().st_size > 10_000
    # one controller with a known budget: no figure to draw
    write_report({"full a": runs["full a"], "zero": runs["zero"]}, tmp_path / "one",
                 "one", provenance=provenance)
    assert not (tmp_path / "one" / "stuck_low_vs_budget.png").exists()


def test_eval_restricts_the_sweep_grid_and_refuses_what_does_not_apply():
    from argparse import Namespace

    from hybrid_recovery.cli.cmd_eval import _scenarios
    from hybrid_recovery.cli.errors import UsageError

    def args(protocol, **grid):
        return Namespace(protocol=protocol, trials=1, seed=0, duration=6.0, poses=None, **grid)

    picked = _scenarios(args("sweep", forces=[0.0, 300.0], directions=["left", "right"],
                             heights=[0.6]))
    assert len(picked) == 5 * 2 * 2 * 1
    assert {s.force for s in picked} == {0.0, 300.0} and {s.height for s in picked} == {0.6}
    assert {s.direction for s in picked} == {SWEEP_DIRECTIONS["left"], SWEEP_DIRECTIONS["right"]}
    with pytest.raises(UsageError) as info:
        _scenarios(args("pushes", heights=[0.2]))
    assert str(info.value) == "eval: --heights does not apply to the pushes protocol"
    with pytest.raises(UsageError) as info:
        _scenarios(args("poses", forces=[100.0]))
    assert str(info.value) == "eval: --forces does not apply to the poses protocol"
