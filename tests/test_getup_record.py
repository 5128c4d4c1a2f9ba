"""Recorded hybrid rises and the hand-over map: contents, starts and exact errors."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.evaluation.getup_record import record_rises
from hybrid_recovery.evaluation.handover_map import handover_map, handover_start
from hybrid_recovery.getup.ground_state import classify, read_ground_pose
from hybrid_recovery.policy import is_shipped
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.sim.initial_states import POSES


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_record_keeps_a_successful_rise_with_its_phases_and_contacts(tmp_path):
    out = record_rises("prone", 1, tmp_path / "rises.npz", duration=20.0, seed=1,
                       policy="shipped")
    assert out == {"attempted": 1, "kept": 1, "path": tmp_path / "rises.npz"}
    rec = np.load(tmp_path / "rises.npz")
    n = len(rec["time"])
    assert rec["qpos"].shape == (n, 34) and rec["qvel"].shape == (n, 33)
    assert rec["contacts"].shape == (n, len(rec["contact_bodies"]))
    assert (rec["episode"] == 0).all() and rec["seeds"].tolist() == [1]
    np.testing.assert_allclose(np.diff(rec["time"]), 0.02, atol=1e-9)
    phases = list(dict.fromkeys(rec["phase"].tolist()))
    # the QP may take over from the policy before the success criterion ends the trial
    assert phases in (["settle", "tuck/knee_chest", "policy"],
                      ["settle", "tuck/knee_chest", "policy", "qp"])
    # the moves' joint targets, exactly where the moves act, within the 0.9× ranges
    moving = np.array(["/" in p for p in rec["phase"]])
    lo, hi = SafetyLimits.from_model(load_torque_model()).q_ref_bounds(0.9)
    for key in ("target", "goal"):
        assert np.isfinite(rec[key][moving]).all() and np.isnan(rec[key][~moving]).all()
        assert ((rec[key][moving] >= lo - 1e-9) & (rec[key][moving] <= hi + 1e-9)).all()
    # the targets reach the phase's keyframe by its end (the hold)
    last = np.flatnonzero(moving)[-1]
    np.testing.assert_allclose(rec["target"][last], rec["goal"][last], atol=1e-9)
    bodies = rec["contact_bodies"].tolist()
    knee = bodies.index("left_knee_link")
    at_handover = rec["phase"].tolist().index("policy")
    assert rec["contacts"][at_handover - 1, knee]  # knee-chest: the knee is down
    # the last sample stands: the pelvis high, no body but the feet on the floor
    assert rec["qpos"][-1, 2] > 0.9
    down = {bodies[b] for b in np.flatnonzero(rec["contacts"][-1])}
    assert down <= {"left_ankle_roll_link", "right_ankle_roll_link"}
    assert rec["recovery_time"][0] <= rec["time"][-1]


def test_handover_start_settles_in_knee_chest():
    model = load_torque_model()
    data = handover_start(model, "knee_chest", np.random.default_rng(0), noise=0.5)
    mujoco.mj_forward(model, data)
    assert classify(read_ground_pose(model, data)) == "knee_chest"


def test_bad_input_messages(tmp_path):
    cases = [
        (lambda: record_rises("flying", 1, tmp_path / "x.npz", policy="shipped"),
         f"unknown pose 'flying': choose one of {list(POSES)}"),
        (lambda: record_rises("prone", 0, tmp_path / "x.npz", policy="shipped"),
         "episodes must be >= 1, got 0"),
        (lambda: record_rises("sitting", 1, tmp_path / "x.npz", controller="qp"),
         "unknown recording controller 'qp': one of ['hybrid', 'model']"),
        (lambda: record_rises("sitting", 1, tmp_path / "x.npz"),
         "the hybrid records with the policy after its hand-over: give --policy"),
        (lambda: record_rises("sitting", 1, tmp_path / "x.npz", policy="shipped",
                              controller="model"),
         "the model controller runs no policy: --policy is the hybrid's"),
        (lambda: handover_map(trials=0), "trials must be >= 1, got 0"),
        (lambda: handover_map(("hovering",)),
         "unknown hand-over state 'hovering': use one of ['hands_knees', 'knee_chest', "
         "'kneel_upright', 'side_sit']"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError) as err:
            call()
        assert str(err.value) == message


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A training run of one iteration (its policy does not rise: trials count as risen
    where a test needs a kept rise)."""
    from hybrid_recovery.training import TrainConfig, train

    run = tmp_path_factory.mktemp("run")
    cfg = TrainConfig(num_envs=4, iterations=1, save_interval=1, num_threads=1,
                      env_overrides={"curriculum.window": 8})
    cfg.ppo.mixed_precision = False
    train(run, cfg)
    return run


@pytest.fixture
def risen(monkeypatch):
    """Trials of the recording run for real and count as risen; the policies loaded."""
    from hybrid_recovery.evaluation import getup_record
    from hybrid_recovery.policy import onnx_policy

    loaded = []
    real_trial, real_init = getup_record.run_trial, onnx_policy.OnnxPolicy.__init__

    def init(self, path, *args, **kwargs):
        loaded.append(str(path))
        real_init(self, path, *args, **kwargs)

    monkeypatch.setattr(getup_record, "run_trial",
                        lambda *a, **k: {**real_trial(*a, **k), "success": True,
                                         "recovery_time": 0.5})
    monkeypatch.setattr(onnx_policy.OnnxPolicy, "__init__", init)
    return loaded


def test_record_runs_the_policy_of_a_run_directory(tmp_path, tiny_run, risen):
    out = record_rises("sitting", 2, tmp_path / "sitting.npz", duration=1.0, seed=4,
                       policy=tiny_run)
    assert out == {"attempted": 2, "kept": 2, "path": tmp_path / "sitting.npz"}
    assert np.load(tmp_path / "sitting.npz")["seeds"].tolist() == [4, 5]
    # the run's checkpoint, exported to a temporary directory that is gone afterwards
    assert risen and all("policy-" in path for path in risen)
    assert not any(Path(path).exists() for path in risen)


def test_record_runs_an_exported_policy_and_names_the_npz_it_writes(tmp_path, tiny_run,
                                                                    risen, capsys):
    from hybrid_recovery.cli.main import main
    from hybrid_recovery.training.export import export_policy

    exported = export_policy(tiny_run, tmp_path / "export")
    assert main(["getup", "record", "--pose", "supine", "--episodes", "1", "--duration", "1",
                 "--policy", str(exported), "--out", str(tmp_path / "rec")]) == 0
    assert capsys.readouterr().out.endswith(f"kept 1 of 1 rises: {tmp_path / 'rec.npz'}\n")
    assert (tmp_path / "rec.npz").is_file() and not (tmp_path / "rec").exists()
    assert risen and {Path(p) if Path(p).is_dir() else Path(p).parent for p in risen} == {exported}


def test_record_refuses_a_missing_or_damaged_policy_in_one_line(tmp_path, tiny_run, capsys):
    from hybrid_recovery.cli.main import main
    from hybrid_recovery.training.export import export_policy

    args = ["getup", "record", "--pose", "sitting", "--episodes", "1",
            "--out", str(tmp_path / "x.npz"), "--policy"]
    assert main([*args, str(tmp_path / "nope")]) == 2
    assert capsys.readouterr().err == (
        f"error: policy directory not found: {tmp_path / 'nope'}; --policy takes an exported "
        "policy, its policy.onnx, a training run directory or 'shipped'\n")
    damaged = export_policy(tiny_run, tmp_path / "damaged", record=False)
    (damaged / "policy.onnx").write_bytes(b"not a model")
    assert main([*args, str(damaged)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: cannot load policy {damaged}: ") and err.count("\n") == 1
    assert not (tmp_path / "x.npz").exists()
    # the hybrid needs a policy, the model controller runs none
    base = ["getup", "record", "--pose", "sitting", "--episodes", "1", "--out", "x.npz"]
    assert main(base) == 2
    assert capsys.readouterr().err == ("error: the hybrid records with the policy after its "
                                       "hand-over: give --policy\n")
    assert main([*base, "--controller", "model", "--policy", "shipped"]) == 2
    assert capsys.readouterr().err == ("error: the model controller runs no policy: --policy "
                                       "is the hybrid's\n")


def test_record_of_the_model_controller_names_its_moves_and_their_targets(tmp_path, risen):
    out = record_rises("sitting", 1, tmp_path / "model.npz", duration=1.5, seed=2,
                       controller="model")
    assert out["kept"] == 1 and risen == []  # no policy loaded
    rec = np.load(tmp_path / "model.npz")
    phases = list(dict.fromkeys(rec["phase"].tolist()))
    assert phases[0] == "settle" and len(phases) > 1
    assert all(p.count("/") == 1 for p in phases[1:])  # <move>/<keyframe>, as the hybrid's
    moving = np.array(["/" in p for p in rec["phase"]])
    assert np.isfinite(rec["target"][moving]).all() and np.isnan(rec["target"][~moving]).all()


def test_record_never_overwrites_and_writes_nothing_without_a_rise(tmp_path, tiny_run,
                                                                   monkeypatch, capsys):
    from hybrid_recovery.cli.main import main
    from hybrid_recovery.evaluation import getup_record

    good = tmp_path / "good.npz"
    good.write_bytes(b"a good recording")
    args = ["getup", "record", "--pose", "sitting", "--episodes", "1", "--duration", "1",
            "--policy", str(tiny_run), "--out"]
    assert main([*args, str(good)]) == 2
    assert capsys.readouterr().err == (f"error: {good} already holds a recording; pass --force "
                                       "to overwrite it\n")
    monkeypatch.setattr(getup_record, "run_trial", lambda *a, **k: {"success": False})
    assert main([*args, str(good), "--force"]) == 2  # nothing kept: the good one stays
    assert capsys.readouterr().err == (f"error: no rise kept from sitting in 1 episodes: "
                                       f"nothing written to {good}\n")
    assert good.read_bytes() == b"a good recording"
    assert list(tmp_path.iterdir()) == [good]  # no temporary file left


@pytest.mark.parametrize(("args", "message"), [
    (["map", "--noise", "nan"], "argument --noise: must be a finite number from 0 to 5, got 'nan'"),
    (["map", "--trials", "0"], "argument --trials: must be an integer >= 1, got '0'"),
    (["map", "--duration", "inf"], "argument --duration: must be a finite number > 0, got 'inf'"),
    (["map", "--seed", "-3"], "argument --seed: must be an integer >= 0, got '-3'"),
    (["margins", "--seed", "-2"], "argument --seed: must be an integer >= 0, got '-2'"),
    (["record", "--pose", "sitting", "--episodes", "0", "--policy", "shipped", "--out", "x"],
     "argument --episodes: must be an integer >= 1, got '0'"),
])
def test_getup_refuses_numbers_at_the_edge(args, message, capsys):
    from hybrid_recovery.cli.main import main

    with pytest.raises(SystemExit) as stop:
        main(["getup", *args])
    assert stop.value.code == 2
    assert capsys.readouterr().err.strip().endswith(f"error: {message}")


@pytest.mark.parametrize("args", [["map", "--trials", "1", "--out"],
                                  ["margins", "--out"], ["margins", "--plot"]])
def test_getup_outputs_are_kept_without_force(args, tmp_path, capsys):
    from hybrid_recovery.cli.main import main

    kept = tmp_path / "kept"
    kept.write_text("earlier results")
    assert main(["getup", *args, str(kept)]) == 2
    assert capsys.readouterr().err == (f"error: {kept} already exists; pass --force to "
                                       "overwrite it\n")
    assert kept.read_text() == "earlier results"


def test_record_names_an_output_it_cannot_write_before_any_trial(tmp_path, capsys,
                                                                monkeypatch):
    from hybrid_recovery.cli.main import main
    from hybrid_recovery.evaluation import getup_record

    monkeypatch.setattr(getup_record, "run_trial", lambda *a, **k: pytest.fail("a trial ran"))
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    out = blocker / "x.npz"
    assert main(["getup", "record", "--pose", "sitting", "--episodes", "1", "--policy",
                 "shipped", "--out", str(out)]) == 2
    assert capsys.readouterr().err == f"error: cannot write {out}: {blocker} is not a directory\n"
