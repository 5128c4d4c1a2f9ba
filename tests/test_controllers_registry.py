"""One registry of controllers: every name builds a :class:`Controller` and resolves in
every command that takes ``--controller``; an unknown name lists the known ones."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from hybrid_recovery.cli.main import _register_all
from hybrid_recovery.cli.registry import COMMANDS
from hybrid_recovery.cli.validate import CONTROLLER_HELP
from hybrid_recovery.controllers import CONTROLLERS, OUTPUT_KINDS, Controller, make
from hybrid_recovery.controllers.registry import entry
from hybrid_recovery.policy import SHIPPED, is_shipped, resolve_policy
from hybrid_recovery.robot.action import TARGET_RANGE_FACTOR

UNKNOWN = ("unknown controller 'nope': known controllers are hybrid, learned, model, onnx, "
           "qp, zero")
COMMANDS_WITH_CONTROLLER = ("eval", "compare", "demo", "play", "sim2sim", "run-robot")
needs_policy = pytest.mark.skipif(not is_shipped(), reason="no shipped policy")


def _spec(name: str) -> str:
    return f"onnx:{resolve_policy(SHIPPED)}" if name == "onnx" else name


def _specs() -> list:
    return [pytest.param(name, marks=needs_policy) if CONTROLLERS[name].policy != "none"
            else name for name in CONTROLLERS]


def _parser(command: str) -> argparse.ArgumentParser:
    _register_all()
    parser = argparse.ArgumentParser()
    COMMANDS[command][1].configure(parser)  # type: ignore[attr-defined]
    return parser


def test_the_registry_holds_the_five_controllers_and_the_help_names_them():
    assert set(CONTROLLERS) == {"zero", "learned", "onnx", "qp", "model", "hybrid"}
    for name in CONTROLLERS:
        assert name in CONTROLLER_HELP
        assert CONTROLLERS[name].outputs and set(CONTROLLERS[name].outputs) <= set(OUTPUT_KINDS)


@pytest.mark.parametrize("name", _specs())
def test_every_name_builds_a_controller_of_the_protocol(name):
    controller = make(_spec(name))
    assert isinstance(controller, Controller)
    assert controller.output == CONTROLLERS[name].outputs[0]
    assert controller.physics_dt > 0 and controller.name.startswith(
        "onnx" if name in ("learned", "onnx") else name)
    assert make(_spec(name), prefer="torque").output == (
        "torque" if "torque" in CONTROLLERS[name].outputs else controller.output)


@pytest.mark.parametrize("name", _specs())
def test_every_name_resolves_in_every_command(name):
    """eval, compare, demo and play build it with :func:`make`; sim2sim and run-robot run
    it in the robot's runner (torque where it offers it)."""
    from hybrid_recovery.deploy.controller_runner import ControllerRunner, make_runner
    from hybrid_recovery.deploy.policy_runner import PolicyRunner

    spec = _spec(name)
    for command in COMMANDS_WITH_CONTROLLER:
        flag = "--controllers" if command == "compare" else "--controller"
        args = _parser(command).parse_args([flag, spec])
        assert spec in np.atleast_1d(getattr(args, flag[2:])), command
    runner = make_runner(spec, TARGET_RANGE_FACTOR)
    if name in ("learned", "onnx"):
        assert isinstance(runner, PolicyRunner) and runner.period_s == 0.02
    else:
        assert isinstance(runner, ControllerRunner)
        assert runner.output == make(spec, prefer="torque").output
        assert runner.period_s == runner.model.opt.timestep


def test_an_unknown_name_lists_the_known_ones():
    from hybrid_recovery.deploy.controller_runner import make_runner

    for build in (make, lambda spec: make_runner(spec, TARGET_RANGE_FACTOR)):
        with pytest.raises(ValueError) as err:
            build("nope")
        assert str(err.value) == UNKNOWN
    with pytest.raises(ValueError) as err:
        entry("qp:x.onnx")
    assert str(err.value) == "controller 'qp' takes no policy path, got 'qp:x.onnx'"
    with pytest.raises(ValueError) as err:
        make("onnx")
    assert str(err.value) == "controller 'onnx' needs a policy path: onnx:PATH"


@pytest.mark.parametrize("argv", [
    ["eval", "--trials", "1"], ["compare", "--trials", "1"], ["play"], ["demo", "--no-video"],
    ["sim2sim", "--no-video"], ["run-robot"]])
def test_each_command_refuses_an_unknown_controller_before_it_runs(capsys, tmp_path, argv):
    from hybrid_recovery.cli.main import main

    flag = "--controllers" if argv[0] == "compare" else "--controller"
    out = [] if argv[0] == "run-robot" else ["--out", str(tmp_path / "out")]
    assert main([*argv, flag, "nope", *out]) == 2
    assert capsys.readouterr().err == f"error: {UNKNOWN}\n"
    assert not (tmp_path / "out").exists()
