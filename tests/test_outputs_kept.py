"""The commands that write a named output refuse an existing one without ``--force``
(``play``'s video, ``sim2sim``'s run directory), before any work and with one line."""

from __future__ import annotations

import pytest

from hybrid_recovery.cli.main import main


def test_play_keeps_an_existing_video(tmp_path, capsys):
    video = tmp_path / "take.mp4"
    video.write_bytes(b"an earlier take")
    assert main(["play", "--policy", "zero", "--seconds", "0.2", "--out", str(video)]) == 2
    assert capsys.readouterr().err == (f"error: {video} already exists; pass --force to "
                                       "overwrite it\n")
    assert video.read_bytes() == b"an earlier take"


@pytest.mark.parametrize("held", [["summary.json"], ["trace.csv", "video.mp4"]])
def test_sim2sim_keeps_an_earlier_run(tmp_path, capsys, held):
    out = tmp_path / "run"
    out.mkdir()
    for name in held:
        (out / name).write_text("earlier")
    assert main(["sim2sim", "--policy", "zero", "--seconds", "0.2", "--no-video",
                 "--out", str(out)]) == 2
    assert capsys.readouterr().err == (f"error: {out} already holds a sim2sim run "
                                       f"({', '.join(held)}); pass --force to overwrite it\n")
    assert sorted(p.name for p in out.iterdir()) == sorted(held)


def test_sim2sim_with_force_replaces_the_run_whole(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text("earlier")
    assert main(["sim2sim", "--policy", "zero", "--seconds", "0.2", "--no-video",
                 "--out", str(out), "--force"]) == 0
    assert (out / "summary.json").read_text().startswith("{")
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary file left
