"""Evaluation progress: the header line of a results file is not a resumed trial, and the
bar counts the trials still to run."""

from __future__ import annotations

from hybrid_recovery.evaluation import run_protocol
from hybrid_recovery.evaluation.runner import completed_keys
from hybrid_recovery.evaluation.scenario import poses_protocol


def _bar(err: str) -> str:
    return err.strip().split("\r")[-1]


def test_fresh_then_resumed_progress(tmp_path, capsys):
    scenarios = poses_protocol(5, seed=1, duration=0.5)
    results = tmp_path / "results.jsonl"
    run_protocol(scenarios[:2], "zero", results, workers=1)
    assert completed_keys(results) == {s.key for s in scenarios[:2]}  # not the header
    bar = _bar(capsys.readouterr().err)
    assert "] 2/2 trials (0 resumed) " in bar
    run_protocol(scenarios, "zero", results, workers=1)
    bar = _bar(capsys.readouterr().err)
    assert "] 3/3 trials (2 resumed) " in bar
