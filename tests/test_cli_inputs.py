"""Inputs that would make a run meaningless are refused at the edge, naming the value
(``error: argument --forces: ...``, exit 2, nothing written); ``kill`` of an evaluation is
handled as Ctrl-C; ``report`` refuses what is not a results file."""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hybrid_recovery.cli.errors import sigterm_as_interrupt
from hybrid_recovery.cli.main import main
from hybrid_recovery.evaluation.runner import _init_worker

ROOT = Path(__file__).resolve().parents[1]


def _refused(capsys, argv: list[str]) -> str:
    """The one error line of a refused command (argparse's exit or the CLI's return)."""
    try:
        code = main(argv)
    except SystemExit as exit_:
        code = exit_.code
    assert code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    return captured.err


EVAL = ["eval", "--controller", "zero", "--protocol", "sweep"]


@pytest.mark.parametrize(("argv", "message"), [
    (EVAL + ["--forces", "nan"], "argument --forces: must be a finite number from 0 to 1000 N, "
                                 "got 'nan'"),
    (EVAL + ["--forces", "1e9"], "argument --forces: must be a finite number from 0 to 1000 N, "
                                 "got '1e9'"),
    (EVAL + ["--forces", "-50"], "argument --forces: must be a finite number from 0 to 1000 N, "
                                 "got '-50'"),
    (EVAL + ["--heights", "inf"], "argument --heights: must be a finite number from -1 to 1 m, "
                                  "got 'inf'"),
    (EVAL + ["--heights", "1000"], "argument --heights: must be a finite number from -1 to 1 "
                                   "m, got '1000'"),
    (EVAL + ["--seed", "-5"], "argument --seed: must be an integer >= 0, got '-5'"),
    (EVAL + ["--forces", "300", "100", "300.0"], "argument --forces: duplicate value '300'"),
    (EVAL + ["--heights", "0", "0.0"], "argument --heights: duplicate value '0'"),
    (EVAL + ["--directions", "left", "left"], "argument --directions: duplicate value 'left'"),
    (EVAL + ["--poses", "standing", "supine", "standing"],
     "argument --poses: duplicate value 'standing'"),
    (["compare", "--controllers", "zero", "--seed", "-1"],
     "argument --seed: must be an integer >= 0, got '-1'"),
    (["compare", "--controllers", "zero", "qp", "zero"],
     "argument --controllers: duplicate value 'zero'"),
])
def test_eval_refuses_values_that_make_the_run_meaningless(capsys, tmp_path, argv, message):
    out = tmp_path / "out"
    assert _refused(capsys, [*argv, "--out", str(out)]) == f"error: {message}\n"
    assert not out.exists()


@pytest.mark.parametrize(("protocol", "duration", "message"), [
    ("sweep", "1.5", "must be >= 2.1 s for the sweep protocol (the push ends at 1.1 s, then 1 s "
                     "of standing counts a recovery), got '1.5'"),
    ("pushes", "2", "must be >= 2.1 s for the pushes protocol (the push ends at 1.1 s, then 1 "
                    "s of standing counts a recovery), got '2'"),
    ("poses", "1e-9", "must be >= 1 s for the poses protocol (1 s of standing counts a "
                      "recovery), got '1e-09'"),
])
def test_a_trial_too_short_to_show_a_recovery_is_refused(capsys, tmp_path, protocol, duration,
                                                         message):
    out = tmp_path / "out"
    err = _refused(capsys, ["eval", "--controller", "zero", "--protocol", protocol,
                            "--duration", duration, "--out", str(out)])
    assert err == f"error: argument --duration: {message}\n"
    assert not out.exists()


def test_a_sweep_without_pushes_needs_only_the_standing_second():
    from argparse import Namespace

    from hybrid_recovery.cli.cmd_eval import _scenarios

    args = Namespace(protocol="sweep", trials=1, seed=0, duration=1.5, poses=["standing"],
                     forces=[0.0], directions=None, heights=[0.0])
    assert [s.duration for s in _scenarios(args)] == [1.5] * 4


def test_a_model_without_a_free_joint_is_named(capsys, tmp_path):
    source = (ROOT / "models" / "h1_2" / "h1_2.xml").read_text()
    assert '<freejoint name="floating_base_joint"/>' in source
    model = tmp_path / "fixed_base.xml"
    model.write_text(source.replace('<freejoint name="floating_base_joint"/>', ""))
    for argv in (["eval", "--controller", "zero", "--out", str(tmp_path / "out")],
                 ["sim2sim", "--policy", "zero", "--out", str(tmp_path / "out")]):
        err = _refused(capsys, [*argv, "--model", str(model)])
        assert err == (f"error: H1-2 MJCF {model} has no free joint before its other joints: "
                       "the floating base needs one (<freejoint/> in the pelvis body)\n")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("argv", "message"), [
    (["play", "--push", "1e9"], "argument --push: must be a finite number from 0 to 1000 N, "
                                "got '1e9'"),
    (["play", "--seed", "-5"], "argument --seed: must be an integer >= 0, got '-5'"),
    (["play", "--push", "100", "--push-time", "6", "--seconds", "5"],
     "argument --push-time: the push starts at 6 s, when the 5 s run is over (--seconds)"),
    (["sim2sim", "--push", "nan"], "argument --push: must be a finite number from 0 to 1000 N, "
                                   "got 'nan'"),
    (["sim2sim", "--delay-ms", "1e6"], "argument --delay-ms: must be a finite number from 0 to "
                                       "1000 ms, got '1e6'"),
    (["sim2sim", "--push", "100", "--seconds", "1"],
     "argument --push-time: the push starts at 2 s, when the 1 s run is over (--seconds)"),
    (["demo", "--balance", "--push", "1e9"], "argument --push: must be a finite number from 0 "
                                             "to 1000 N, got '1e9'"),
    (["bench", "qp", "sweep", "--forces", "0:500:0"],
     "argument --forces: must be start:stop:step [N] with 0 <= start <= stop <= 1000 and "
     "step > 0, got '0:500:0'"),
    (["bench", "qp", "sweep", "--forces", "0:nan:50"],
     "argument --forces: must be start:stop:step [N] with 0 <= start <= stop <= 1000 and "
     "step > 0, got '0:nan:50'"),
    (["bench", "qp", "sweep", "--directions", "+x,up"],
     "argument --directions: unknown direction 'up': choose from +x,-x,+y,-y, got '+x,up'"),
    (["bench", "qp", "sweep", "--directions", "+x,-y,+x"],
     "argument --directions: duplicate value '+x'"),
    (["bench", "qp", "timing", "--timing-push", "inf"],
     "argument --timing-push: must be a finite number from 0 to 1000 N, got 'inf'"),
    (["bench", "dynamics", "--seed", "-1"], "argument --seed: must be an integer >= 0, got '-1'"),
])
def test_other_commands_refuse_inputs_that_reach_the_physics(capsys, tmp_path, monkeypatch,
                                                            argv, message):
    monkeypatch.chdir(tmp_path)  # nothing written: the default outputs would land here
    assert _refused(capsys, argv) == f"error: {message}\n"
    assert list(tmp_path.iterdir()) == []


def test_the_bench_force_grid_ends_at_its_stop():
    from hybrid_recovery.cli.cmd_bench import _force_grid

    assert _force_grid("0:500:50") == [50.0 * k for k in range(11)]
    assert _force_grid("0:100:60") == [0.0, 60.0]  # not past the stop
    assert _force_grid("250:250:0") == [250.0]


def test_report_refuses_what_is_not_a_results_file(capsys, tmp_path):
    out = tmp_path / "report"
    plain = tmp_path / "notes.txt"
    plain.write_text("a plain text file\nof two lines\n")
    headless = tmp_path / "results.jsonl"
    headless.write_text('{"key": "standing|0", "pose": "standing", "success": true}\n')
    for path in (plain, headless):
        err = _refused(capsys, ["report", str(path), "--out", str(out)])
        assert err == (f"error: {path} is not a results file of this harness (no header line); "
                       "give the results.jsonl that eval or compare wrote\n")
    err = _refused(capsys, ["report", "--out", str(out)])
    assert err == ("error: report: nothing to report; give results.jsonl files of eval or "
                   "compare, or training runs with --runs\n")
    assert not out.exists()


def test_sigterm_during_eval_is_handled_as_ctrl_c(tmp_path):
    out = tmp_path / "eval"
    results = out / "results.jsonl"
    cmd = [sys.executable, "-m", "hybrid_recovery.cli.main", "eval", "--controller", "zero",
           "--trials", "200", "--duration", "3", "--workers", "2", "--out", str(out)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, start_new_session=True)
    deadline = time.time() + 180
    while time.time() < deadline and proc.poll() is None:
        if results.is_file() and len(results.read_text().splitlines()) >= 4:
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
    proc.send_signal(signal.SIGTERM)  # as `kill <pid>`: the parent alone
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "Traceback" not in err and "BrokenPipeError" not in err
    lines = results.read_text().splitlines()
    trials = len(lines) - 1
    assert 3 <= trials < 200
    assert err.strip().splitlines()[-1] == (f"interrupted: {trials} of 200 trials are in "
                                            f"{results}; the same command resumes")


def _worker_sigterm(queue) -> None:
    _init_worker("zero", None, "default", ignore_sigint=True)
    queue.put(signal.getsignal(signal.SIGTERM) is signal.SIG_DFL)


def test_an_evaluation_worker_ends_on_sigterm_wherever_it_blocks():
    ctx = mp.get_context("fork")
    with sigterm_as_interrupt():  # the parent's handler, which a forked worker inherits
        queue = ctx.Queue()
        worker = ctx.Process(target=_worker_sigterm, args=(queue,))
        worker.start()
        default = queue.get(timeout=120)
        worker.join(60)
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL  # the parent keeps it
    assert default
