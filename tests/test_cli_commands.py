"""One entry point: every benchmark under ``bench``, the robot runners as subcommands."""

from __future__ import annotations

import pytest

from hybrid_recovery.cli.main import COMMANDS, _register_all, main


def test_the_robot_runners_and_one_bench_are_subcommands():
    _register_all()
    assert {"bench", "run-robot", "sim-robot", "train"} <= set(COMMANDS)
    assert not {"bench-qp", "bench-deploy"} & set(COMMANDS)


def test_bench_lists_every_target(capsys):
    with pytest.raises(SystemExit) as done:
        main(["bench", "--help"])
    assert done.value.code == 0
    assert "{dynamics,env,terms,train,qp,deploy}" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["bench", "qp", "--stepping", "sometimes"])
    assert "invalid choice: 'sometimes'" in capsys.readouterr().err


def test_train_refuses_an_unknown_variant(tmp_path, capsys):
    assert main(["train", "--variant", "best", "--run-dir", str(tmp_path / "run")]) == 2
    assert capsys.readouterr().err == ("error: unknown variant 'best': choose one of ['full', "
                                       "'no_capture_point', 'no_curriculum', 'no_privileged', "
                                       "'recovery', 'recovery_model_rises', 'recovery_rises', "
                                       "'reduced']\n")
    assert not (tmp_path / "run").exists()
