"""``eval``/``compare``/``play`` with ``--terrain`` and ``--actuator``: bad input is one
line and nothing is written; a run records the terrain and the motor figures per trial
and reports them (a table per terrain, the motors' table)."""

from __future__ import annotations

import json

import pytest
from test_cli_inputs import _refused

from hybrid_recovery.cli.main import main


@pytest.mark.parametrize(("argv", "message"), [
    (["eval", "--terrain", "slope:91"],
     "argument --terrain: terrain 'slope:91': the slope must be within ±45 deg, got 91"),
    (["eval", "--terrain", "rough:-1"],
     "argument --terrain: terrain 'rough:-1': the height must be 0 to 20 cm, got -1"),
    (["compare", "--controllers", "zero", "--terrain", "ice"],
     "argument --terrain: unknown terrain 'ice': use flat, slope:DEG[:HEADING], rough:CM or "
     "step:CM"),
    (["eval", "--terrain", "slope:5", "slope:5.0"], "argument --terrain: duplicate value "
                                                    "'slope:5'"),
    (["eval", "--actuator", "servo"],
     "argument --actuator: invalid choice: 'servo' (choose from ideal, dc)"),
    (["eval", "--protocol", "terrain", "--forces", "100"],
     "eval: --forces does not apply to the terrain protocol"),
    (["play", "--terrain", "step:-2"],
     "argument --terrain: terrain 'step:-2': the height must be 0 to 30 cm, got -2"),
    (["play", "--terrain", "slope:5", "--randomize"],
     "play: --randomize does not apply with --terrain (the take is an evaluation trial, "
     "nominal physics)"),
])
def test_bad_terrain_and_motor_options_are_one_line(capsys, tmp_path, argv, message):
    out = tmp_path / "out"
    flag = "--out"
    err = _refused(capsys, [*argv, flag, str(out if argv[0] != "play" else out / "x.mp4")])
    assert err.replace("'ideal', 'dc'", "ideal, dc") == f"error: {message}\n"
    assert not out.exists()


def test_a_terrain_run_with_dc_motors_records_and_reports_them(capsys, tmp_path):
    out = tmp_path / "eval"
    code = main(["compare", "--controllers", "zero", "qp", "--protocol", "terrain",
                 "--terrain", "slope:5", "step:5", "--poses", "supine", "--trials", "1",
                 "--duration", "1.5", "--workers", "1", "--actuator", "dc", "--out", str(out)])
    assert code == 0
    capsys.readouterr()
    rows = [json.loads(line) for line in (out / "c0" / "results.jsonl").read_text().splitlines()]
    header, trials = rows[0], rows[1:]
    assert header["actuator"] == "dc" and header["terrain"] == ["slope:5", "step:5"]
    assert sorted(r["terrain"] for r in trials) == ["slope:5", "step:5"]
    for row in trials:
        assert row["actuator"] == "dc"
        assert 0.0 <= row["over_velocity_share"] <= 1.0
        assert row["worst_velocity_ratio"] > 0.0 and row["time_at_effort_limit"] >= 0.0
    qp = [json.loads(line) for line in (out / "c1" / "results.jsonl").read_text().splitlines()]
    assert all(r["declined"].startswith("qp declines ") for r in qp[1:])
    report = (out / "report.md").read_text()
    assert "## Motors" in report and "## Terrain" in report
    assert "| slope:5 | 0% [0%, 79%] (n=1) | declined |" in report
    assert (out / "terrain.png").is_file()
