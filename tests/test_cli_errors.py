"""The CLI's one error mechanism and its checks at the edge: ``error: <message>`` and exit 2
(the traceback only with ``--debug``), Ctrl-C one line and exit 130, and a run that fails
its checks writes nothing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hybrid_recovery.cli.errors import report_errors
from hybrid_recovery.cli.main import main

ROOT = Path(__file__).resolve().parents[1]


def _error(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and "Traceback" not in captured.err
    return captured.err


def test_a_missing_policy_directory_is_named_and_nothing_written(tmp_path, capsys):
    out = tmp_path / "out"
    missing = tmp_path / "no_such_policy"
    err = _error(capsys, ["eval", "--controller", f"onnx:{missing}", "--out", str(out)])
    assert err == f"error: policy directory not found: {missing}\n"
    assert not out.exists()


def test_compare_checks_every_controller_before_any_runs(tmp_path, capsys):
    out = tmp_path / "out"
    err = _error(capsys, ["compare", "--controllers", "zero", "bogus", "--trials", "1",
                          "--out", str(out)])
    assert err == ("error: unknown controller 'bogus': known controllers are hybrid, learned, "
                   "model, onnx, qp, zero\n")
    assert not out.exists()


def test_contact_and_model_are_checked_first(tmp_path, capsys):
    out = tmp_path / "out"
    err = _error(capsys, ["eval", "--controller", "zero", "--contact", "icy", "--out", str(out)])
    assert err == ("error: unknown contact preset 'icy': choose one of ['default', 'slippery', "
                   "'grippy', 'soft', 'stiff', 'bouncy']\n")
    missing = tmp_path / "robot.xml"
    err = _error(capsys, ["eval", "--controller", "zero", "--model", str(missing),
                          "--out", str(out)])
    assert err == f"error: H1-2 MJCF not found: {missing}\n"
    missing.write_text("<mujoco><worldbody><body")
    err = _error(capsys, ["eval", "--controller", "zero", "--model", str(missing),
                          "--out", str(out)])
    assert err.startswith(f"error: cannot parse H1-2 MJCF {missing}: XML parse error")
    assert not out.exists()


def test_report_names_a_missing_results_file(tmp_path, capsys):
    missing = tmp_path / "results.jsonl"
    err = _error(capsys, ["report", str(missing), "--out", str(tmp_path / "report")])
    assert err == f"error: results file not found: {missing}\n"
    assert not (tmp_path / "report").exists()


@pytest.mark.parametrize(("option", "value", "expected"), [
    ("--trials", "-5", "an integer >= 1"),
    ("--trials", "2.5", "an integer >= 1"),
    ("--duration", "-1", "a finite number > 0"),
    ("--duration", "nan", "a finite number > 0"),
    ("--workers", "0", "an integer >= 1"),
])
def test_numbers_are_checked_by_the_parser(capsys, option, value, expected):
    with pytest.raises(SystemExit) as info:
        main(["eval", "--controller", "zero", option, value])
    assert info.value.code == 2
    assert capsys.readouterr().err == (f"error: argument {option}: must be {expected}, "
                                       f"got '{value}'\n")


def test_debug_adds_the_traceback(capsys):
    assert main(["--debug", "eval", "--controller", "bogus"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("Traceback (most recent call last):")
    assert err.endswith("error: unknown controller 'bogus': known controllers are hybrid, "
                        "learned, model, onnx, qp, zero\n")
    assert main(["eval", "--debug", "--controller", "bogus"]) == 2  # after the subcommand too
    assert capsys.readouterr().err.startswith("Traceback")


def test_an_unexpected_exception_is_named_as_a_bug(capsys):
    def buggy() -> int:
        return None + 1  # type: ignore[operator]

    assert report_errors(buggy, debug=False) == 2
    assert capsys.readouterr().err == (
        "error: TypeError: unsupported operand type(s) for +: 'NoneType' and 'int' (a bug: "
        "run with --debug for the traceback and report it)\n")


def test_interrupt_is_one_line_and_exit_130(capsys):
    def interrupted() -> int:
        raise KeyboardInterrupt

    assert report_errors(interrupted, debug=False) == 130
    assert capsys.readouterr().err == "interrupted\n"


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_ctrl_c_during_eval_keeps_the_finished_trials(tmp_path):
    out = tmp_path / "eval"
    results = out / "results.jsonl"
    cmd = [sys.executable, "-m", "hybrid_recovery.cli.main", "eval", "--controller", "zero",
           "--trials", "200", "--duration", "3", "--workers", "2", "--out", str(out)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, start_new_session=True,  # SIGINT handled even when the
                            preexec_fn=_default_sigint)        # tests run as a background job
    deadline = time.time() + 180
    while time.time() < deadline and proc.poll() is None:
        if results.is_file() and len(results.read_text().splitlines()) >= 4:
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
    os.killpg(proc.pid, signal.SIGINT)  # as a terminal's Ctrl-C: parent and workers
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    last = err.strip().splitlines()[-1]
    lines = results.read_text().splitlines()
    trials = len(lines) - 1
    assert 3 <= trials < 200
    assert last == (f"interrupted: {trials} of 200 trials are in {results}; the same command "
                    "resumes")
