"""A results file holds one run's trials, each once: one writer at a time (the second is
refused naming the first's pid), rows deduplicated by key when read, a resume refused when
the model or policy file's contents changed, no header before the first row, and a line
that is not a result row named with its file and line."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from hybrid_recovery.cli.main import main
from hybrid_recovery.evaluation import load_results, run_protocol
from hybrid_recovery.evaluation.runner import completed_keys
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.files import FileLockedError, sha256_file
from hybrid_recovery.robot.mjcf import H1_2_MJCF

ROOT = Path(__file__).resolve().parents[1]
TRIAL = ["--trials", "1", "--poses", "standing", "--duration", "1", "--workers", "1"]
HOLD = ("import sys, time\n"
        "from hybrid_recovery.files import exclusive_lock\n"
        "with exclusive_lock(sys.argv[1]):\n"
        "    print('held', flush=True)\n"
        "    time.sleep(60)\n")


def _scenarios(count: int = 1) -> list[Scenario]:
    return [Scenario("standing", duration=0.1, noise=0.0, seed=k) for k in range(count)]


@pytest.fixture
def holder(tmp_path):
    """Another process holding the lock of a path: ``holder(path)`` → its pid."""
    procs = []

    def hold(path: Path) -> int:
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        proc = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], env=env,
                                stdout=subprocess.PIPE, text=True)
        procs.append(proc)
        assert proc.stdout is not None and proc.stdout.readline() == "held\n"
        return proc.pid

    yield hold
    for proc in procs:
        proc.kill()
        proc.wait()


def test_a_second_eval_into_the_same_output_is_refused_naming_the_first(tmp_path, holder,
                                                                       capsys):
    out = tmp_path / "eval"
    pid = holder(out)
    assert main(["eval", "--controller", "zero", *TRIAL, "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"error: {out} is in use by another process (pid {pid}); wait for it to end or "
        "choose another --out\n")
    assert not (out / "results.jsonl").exists()


def test_a_second_writer_of_a_results_file_is_refused_naming_the_first(tmp_path, holder):
    results = tmp_path / "results.jsonl"
    pid = holder(results)
    with pytest.raises(FileLockedError) as info:
        run_protocol(_scenarios(), "zero", results, workers=1, progress=False)
    assert str(info.value) == (f"{results} is in use by another process (pid {pid}); wait "
                               "for it to end or choose another --out")
    assert not results.exists()


def test_rows_are_read_once_per_key(tmp_path, capsys):
    results = tmp_path / "results.jsonl"
    run_protocol(_scenarios(2), "zero", results, workers=1, progress=False)
    lines = results.read_text().splitlines()
    with results.open("a") as f:  # a second writer appended the same trials
        f.write("\n".join(lines[1:]) + "\n")
    rows = load_results(results)
    assert [r["key"] for r in rows] == ["__header__", *(s.key for s in _scenarios(2))]
    assert len(run_protocol(_scenarios(2), "zero", results, workers=1, progress=False)) == 2
    assert main(["report", str(results), "--out", str(tmp_path / "report")]) == 0
    capsys.readouterr()
    report = (tmp_path / "report" / "report.md").read_text()
    assert "| standing | 2 |" in report


def test_a_resume_with_a_changed_model_file_is_refused_naming_it(tmp_path, capsys):
    model = tmp_path / "m.xml"
    shutil.copy(H1_2_MJCF, model)
    out = tmp_path / "eval"
    argv = ["eval", "--controller", "zero", *TRIAL, "--model", str(model), "--out", str(out)]
    assert main(argv) == 0
    header = json.loads((out / "results.jsonl").read_text().splitlines()[0])
    old = header["sha256"]["model"]
    assert old == sha256_file(model)
    before = (out / "results.jsonl").read_text()
    model.write_text(model.read_text() + "<!-- edited -->\n")
    capsys.readouterr()
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        f"error: {out / 'results.jsonl'} holds results of other file contents: the model "
        f"file {model} (sha256 {old[:12]} there, {sha256_file(model)[:12]} now) changed; "
        "choose another --out or remove it to start anew\n")
    assert (out / "results.jsonl").read_text() == before


def test_a_resume_with_another_policy_of_the_same_name_is_refused_naming_it(tmp_path):
    from hybrid_recovery.training.stand_in import write_stand_in_policy

    policy = write_stand_in_policy(tmp_path / "policy", "random", seed=0)
    results = tmp_path / "results.jsonl"
    run_protocol(_scenarios(), f"onnx:{policy}", results, workers=1, progress=False)
    old = sha256_file(policy / "policy.onnx")
    write_stand_in_policy(tmp_path / "policy", "random", seed=1)  # same provenance
    with pytest.raises(ValueError) as info:
        run_protocol(_scenarios(2), f"onnx:{policy}", results, workers=1, progress=False)
    assert str(info.value) == (
        f"{results} holds results of other file contents: the policy file "
        f"{policy / 'policy.onnx'} (sha256 {old[:12]} there, "
        f"{sha256_file(policy / 'policy.onnx')[:12]} now) changed; choose another --out or "
        "remove it to start anew")


def test_a_results_file_without_hashes_is_not_resumed_for_a_policy(tmp_path):
    results = tmp_path / "results.jsonl"
    run_protocol(_scenarios(), "learned", results, workers=1, progress=False)
    header, *rows = results.read_text().splitlines()
    old = json.loads(header)
    del old["sha256"]  # as written before the hashes were recorded
    results.write_text("\n".join([json.dumps(old), *rows]) + "\n")
    with pytest.raises(ValueError) as info:
        run_protocol(_scenarios(), "learned", results, workers=1, progress=False)
    assert str(info.value) == (
        f"{results} records no content hashes of its model and policy files, so they "
        "cannot be checked; choose another --out or remove it to start anew")


def test_no_header_is_written_before_the_first_row(tmp_path):
    results = tmp_path / "eval" / "results.jsonl"
    with pytest.raises(ValueError, match="^unknown pose 'flying'"):
        run_protocol([Scenario("flying", duration=0.1)], "zero", results, workers=1,
                     progress=False)
    assert not results.exists() and not results.parent.exists()
    run_protocol(_scenarios(), "zero", results, workers=1, progress=False)
    assert [json.loads(line)["key"] for line in results.read_text().splitlines()] == [
        "__header__", _scenarios()[0].key]


def test_a_line_that_is_not_a_row_is_named_with_its_file_and_line(tmp_path, capsys):
    results = tmp_path / "results.jsonl"
    run_protocol(_scenarios(), "zero", results, workers=1, progress=False)
    with results.open("a") as f:
        f.write("[1, 2]\n")
    expected = (f"{results} line 3 is not a result row (a JSON object with a key): "
                "[1, 2]")
    with pytest.raises(ValueError) as info:
        load_results(results)
    assert str(info.value) == expected
    with pytest.raises(ValueError) as info:
        completed_keys(results)
    assert str(info.value) == expected
    assert main(["report", str(results), "--out", str(tmp_path / "report")]) == 2
    assert capsys.readouterr().err == f"error: {expected}\n"
