"""The off-nominal robot of an evaluation trial: a payload adds exactly its mass to the
torso, weak motors scale the force range, a delay holds every output back by whole physics
steps; the controller keeps the nominal model; the CLI records and validates each option."""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from hybrid_recovery.cli.main import main
from hybrid_recovery.evaluation.off_nominal import ActuationDelay, delay_steps
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import eval_model, run_trial
from hybrid_recovery.robot import constants


def _torso(model: mujoco.MjModel) -> int:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, constants.TORSO_BODY)


@pytest.mark.parametrize("torque", [False, True])
def test_payload_adds_exactly_its_mass_to_the_torso(torque):
    nominal = eval_model(None, 0.005, torque, "default")
    loaded = eval_model(None, 0.005, torque, "default", payload=30.0)
    added = loaded.body_mass - nominal.body_mass
    assert added[_torso(loaded)] == pytest.approx(30.0, abs=1e-12)
    assert np.count_nonzero(added) == 1
    np.testing.assert_array_equal(loaded.body_inertia, nominal.body_inertia)


@pytest.mark.parametrize("torque", [False, True])
def test_motor_strength_scales_the_force_range(torque):
    weak = eval_model(None, 0.005, torque, "default", motor_strength=0.5)
    assert weak.actuator_forcelimited.all()
    np.testing.assert_allclose(weak.actuator_forcerange[:, 1], 0.5 * constants.EFFORT_LIMITS)
    np.testing.assert_allclose(weak.actuator_forcerange[:, 0], -0.5 * constants.EFFORT_LIMITS)


def test_the_delay_fifo_holds_each_output_back_n_steps():
    assert delay_steps(0.06, 0.005) == 12 and delay_steps(0.06, 0.002) == 30
    late = ActuationDelay(3, np.zeros(2))
    out = [late(np.full(2, float(k)))[0] for k in range(1, 7)]
    assert out == [0.0, 0.0, 0.0, 1.0, 2.0, 3.0]
    assert ActuationDelay(0, np.zeros(2))(np.ones(2))[0] == 1.0


class _Spy:
    """A torque controller of tiny distinct outputs that records what it sees."""

    name, physics_dt, output, joint_target = "spy", 0.005, "torque", None

    def reset(self, model, data):
        self.sent, self.applied, self.masses = [], [], []

    def __call__(self, model, data):
        self.applied.append(data.ctrl.copy())  # what the last step applied
        self.masses.append(model.body_mass[_torso(model)])
        command = np.full(model.nu, 1e-3 * (len(self.sent) + 1))
        self.sent.append(command)
        return command


def test_a_trial_delays_the_outputs_and_keeps_the_controller_nominal():
    spy = _Spy()
    row = run_trial(spy, Scenario("standing", duration=0.2, delay=0.03, payload=10.0))
    n = row["delay_steps"]
    assert n == 6 and row["payload"] == 10.0 and row["delay"] == 0.03
    for k in range(n + 1, len(spy.sent)):  # at call k the plant applied output k − 1 − n
        np.testing.assert_array_equal(spy.applied[k], spy.sent[k - 1 - n])
    np.testing.assert_array_equal(spy.applied[n], np.zeros(spy.sent[0].shape))
    nominal = eval_model(None, 0.005, True, "default")
    assert set(spy.masses) == {nominal.body_mass[_torso(nominal)]}


@pytest.mark.parametrize(("field", "value", "message"), [
    ("motor_strength", 0.0, "motor_strength must be a finite number from 0.1 to 2, got 0.0"),
    ("payload", -1.0, "payload must be a finite number from 0 to 60 kg, got -1.0"),
    ("delay", float("inf"), "delay must be a finite number from 0 to 0.2 s, got inf"),
])
def test_a_scenario_refuses_an_impossible_robot(field, value, message):
    with pytest.raises(ValueError) as info:
        Scenario("standing", **{field: value})
    assert str(info.value) == message


def test_the_key_names_the_robot_only_off_nominal():
    assert "strength" not in Scenario("standing").key
    assert Scenario("standing", payload=30.0).key.endswith("|strength=1|payload=30|delay=0")


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--motor-strength", "0", "argument --motor-strength: must be a finite number from 0.1 to "
                              "2, got '0'"),
    ("--payload", "70", "argument --payload: must be a finite number from 0 to 60 kg, "
                        "got '70'"),
    ("--delay", "-0.01", "argument --delay: must be a finite number from 0 to 0.2 s, "
                         "got '-0.01'"),
])
def test_the_cli_refuses_an_impossible_robot(capsys, tmp_path, option, value, message):
    with pytest.raises(SystemExit) as exit_:
        main(["eval", "--controller", "zero", "--out", str(tmp_path / "r"), option, value])
    assert exit_.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(message)
    assert not (tmp_path / "r").exists()


def test_eval_records_the_robot_in_the_header_and_every_row(tmp_path):
    out = tmp_path / "r"
    assert main(["eval", "--controller", "zero", "--trials", "2", "--duration", "1",
                 "--workers", "1", "--out", str(out), "--motor-strength", "0.5",
                 "--payload", "30", "--delay", "0.06"]) == 0
    header, *rows = [json.loads(line) for line in (out / "results.jsonl").read_text()
                     .splitlines()]
    assert (header["motor_strength"], header["payload"], header["delay"]) == (0.5, 30.0, 0.06)
    assert len(rows) == 2
    for row in rows:
        assert (row["motor_strength"], row["payload"], row["delay"]) == (0.5, 30.0, 0.06)
        assert row["delay_steps"] == 12
