"""The staged recipe (``recovery_rises``): a tiny run passes every stage in order,
records with its own policy (never the shipped one), and resumes in the stage a kill
left."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from hybrid_recovery.evaluation import getup_record
from hybrid_recovery.policy import onnx_policy
from hybrid_recovery.recipe.staged_run import StageEnded, train_staged
from hybrid_recovery.training import load_checkpoint
from hybrid_recovery.training.config import StageConfig
from hybrid_recovery.training.stages import STATE_FILE, StageState, stage_config
from hybrid_recovery.training.variants import variant_train_config

FAST = {"curriculum.window": 8, "curriculum.advance_success": 0.0}
STAGES = StageConfig(probe_interval=2, probe_episodes=1, probe_duration=1.5, rise_rate=1.0,
                     record_episodes=2, min_kept=1, poses=("sitting",))
SHIPPED_DIR = Path(__file__).resolve().parents[1] / "models" / "policies"


def _cfg(iterations: int, stages: StageConfig = STAGES):
    cfg = variant_train_config("recovery_rises", num_envs=4, iterations=iterations,
                               num_threads=1, save_interval=1)
    cfg.ppo.mixed_precision = False
    return dataclasses.replace(cfg, stages=stages, env_overrides=dict(FAST))


@pytest.fixture
def policies_loaded(monkeypatch):
    """Every policy file the run loads; trials are real (the run's own exported policy
    after the hybrid's moves) but count as risen, as a trained policy's would."""
    loaded: list[Path] = []
    real_init, real_trial = onnx_policy.OnnxPolicy.__init__, getup_record.run_trial

    def init(self, path, *args, **kwargs):
        loaded.append(Path(path).resolve())
        real_init(self, path, *args, **kwargs)

    def trial(*args, **kwargs):
        row = real_trial(*args, **kwargs)
        return {**row, "success": True, "recovery_time": 1.0}

    monkeypatch.setattr(onnx_policy.OnnxPolicy, "__init__", init)
    monkeypatch.setattr(getup_record, "run_trial", trial)
    return loaded


def _changes(run: Path) -> list[tuple[str, str]]:
    state = StageState.load(run)
    assert state is not None
    return [(c["from"], c["to"]) for c in state.changes]


def test_a_tiny_run_passes_every_stage_in_order_with_its_own_policy(tmp_path, policies_loaded):
    run = tmp_path / "run"
    state = train_staged(run, _cfg(iterations=4))
    assert state.stage == "rises"
    assert _changes(run) == [("recovery", "record"), ("record", "rises")]
    assert [p["iteration"] for p in state.probes] == [1] and state.probes[0]["passed"]
    assert state.probes[0]["stood_up"] == {"sitting": [1, 1]}
    assert state.recordings[0]["kept"] == {"sitting": [2, 2]}
    # the recording is the run's own, where the rises stage reads it
    rec = np.load(run / "rises" / "sitting.npz")
    assert int(rec["attempted"]) == 2 and rec["seeds"].tolist() == [100, 101]
    meta = json.loads((run / "config.json").read_text())
    assert meta["stage"] == "rises"
    assert meta["env_config"]["rises"]["files"] == [str(run / "rises" / "sitting.npz")]
    assert meta["train_config"]["teacher"]["learning_rate"] == 0.0  # the recipe's own
    assert load_checkpoint(run / "latest.pt")["iter"] == 3
    assert load_checkpoint(run / "latest.pt")["infos"]["teacher"] is not None
    # every policy that ran was exported from this run, none is the shipped one
    assert policies_loaded and all(SHIPPED_DIR not in p.parents for p in policies_loaded)
    # the exported record says so, with the stages up to the checkpoint
    from hybrid_recovery.training.export import export_policy

    record = json.loads((export_policy(run, tmp_path / "export") /
                         "training_record.json").read_text())
    assert record["origin"] == "from scratch" and record["amendments"] == []
    assert record["stages"]["stage"] == "rises"
    assert [c["to"] for c in record["stages"]["changes"]] == ["record", "rises"]


def test_a_kill_in_each_stage_resumes_in_that_stage(tmp_path, policies_loaded, monkeypatch):
    run = tmp_path / "run"
    # killed in recovery, before its first probe: resumes in recovery
    train_staged(run, _cfg(iterations=1))
    assert StageState.load(run).stage == "recovery" and _changes(run) == []

    # killed while recording: the probe passed, the recording dies
    def dying(*args, **kwargs):
        if kwargs.get("force"):  # the recording, not the probe
            raise KeyboardInterrupt
        return getup_record.record_rises(*args, **kwargs)

    with pytest.raises(KeyboardInterrupt):
        train_staged(run, _cfg(iterations=6), resume=True, recorder=dying)
    assert StageState.load(run).stage == "record"
    assert not (run / "rises" / "sitting.npz").exists()
    # resumed: records, then trains in rises; stopped at 4 of 6 iterations
    state = train_staged(run, _cfg(iterations=4), resume=True, given={"iterations"})
    assert state.stage == "rises" and load_checkpoint(run / "latest.pt")["iter"] == 3
    assert _changes(run) == [("recovery", "record"), ("record", "rises")]
    # killed in rises: resumes there, with its recordings and the teacher
    state = train_staged(run, _cfg(iterations=5), resume=True, given={"iterations"})
    assert state.stage == "rises" and load_checkpoint(run / "latest.pt")["iter"] == 4
    assert _changes(run) == [("recovery", "record"), ("record", "rises")]


def test_too_few_kept_rises_go_back_to_recovery(tmp_path):
    calls = []

    def recorder(pose, episodes, out, **kwargs):
        calls.append(bool(kwargs.get("force")))
        if kwargs.get("force"):
            raise getup_record.NoRiseKept("none")
        return {"kept": episodes, "attempted": episodes, "path": out}

    state = train_staged(tmp_path / "run", _cfg(iterations=4), recorder=recorder)
    # probe passed at 1, nothing kept: back to recovery; the probe at 3 passes again
    assert _changes(tmp_path / "run")[:3] == [("recovery", "record"), ("record", "recovery"),
                                             ("recovery", "record")]
    assert calls[:3] == [False, True, False]
    assert state.stage in ("record", "recovery")


def test_a_failed_probe_keeps_training_in_recovery(tmp_path, capsys):
    def recorder(pose, episodes, out, **kwargs):
        return {"kept": 0, "attempted": episodes, "path": out}

    state = train_staged(tmp_path / "run", _cfg(iterations=4), recorder=recorder)
    assert state.stage == "recovery" and len(state.probes) == 2
    assert not any(p["passed"] for p in state.probes)
    out = capsys.readouterr().out
    assert ("[recipe] stage recovery, iteration 1: the run's own rises after the hand-over "
            "sitting 0/1 (needs >= 100% each); next probe at iteration 3") in out


def test_the_model_recorder_records_its_rises_without_a_probe_or_a_policy(tmp_path,
                                                                        policies_loaded):
    run = tmp_path / "run"
    stages = dataclasses.replace(STAGES, recorder="model")
    state = train_staged(run, _cfg(iterations=4, stages=stages))
    assert state.stage == "rises" and state.probes == []
    assert _changes(run) == [("recovery", "record"), ("record", "rises")]
    assert state.changes[0]["iteration"] == 1  # after probe_interval iterations
    assert state.recordings[0]["kept"] == {"sitting": [2, 2]}
    rec = np.load(run / "rises" / "sitting.npz")
    phases = set(rec["phase"].tolist())
    assert "policy" not in phases and any("/" in p for p in phases)  # the model's moves
    assert policies_loaded == []  # no policy ran, neither the run's nor the shipped one
    meta = json.loads((run / "config.json").read_text())
    assert meta["train_config"]["stages"]["recorder"] == "model"
    assert load_checkpoint(run / "latest.pt")["infos"]["teacher"] is not None


def test_stage_settings_and_state_checks(tmp_path):
    cfg = _cfg(iterations=1)
    assert stage_config(cfg, "recovery", tmp_path, STAGES) == cfg
    rises = stage_config(cfg, "rises", tmp_path, STAGES)
    assert rises.env_overrides["rises.files"] == [str(tmp_path / "rises" / "sitting.npz")]
    assert rises.env_overrides["rises.levels"] == 16
    assert (rises.teacher.learning_rate, rises.teacher.anneal_iterations) == (1e-4, 300)
    with pytest.raises(ValueError, match="^StageConfig.rise_rate must be in \\(0, 1\\], got 0$"):
        StageConfig(rise_rate=0)
    with pytest.raises(ValueError, match="^StageConfig.probe_interval must be >= 1, got 0$"):
        StageConfig(probe_interval=0)
    with pytest.raises(ValueError, match="^StageConfig.recorder must be 'hybrid' or 'model', "
                                         "got 'qp'$"):
        StageConfig(recorder="qp")
    (tmp_path / STATE_FILE).write_text("{not json")
    with pytest.raises(ValueError, match=f"^stage state {tmp_path / STATE_FILE} is damaged"):
        StageState.load(tmp_path)
    (tmp_path / STATE_FILE).write_text('{"stage": "flying"}')
    with pytest.raises(ValueError, match="names an unknown stage 'flying'$"):
        StageState.load(tmp_path)
    assert isinstance(StageEnded(), Exception)


def test_milestone_checkpoints_are_kept(tmp_path):
    from hybrid_recovery.training import TrainConfig, train

    cfg = TrainConfig(num_envs=4, iterations=7, save_interval=1, keep_checkpoints=2,
                      milestone_interval=3, num_threads=1, env_overrides=dict(FAST))
    cfg.ppo.mixed_precision = False
    train(tmp_path, cfg)
    kept = sorted(int(p.stem[6:]) for p in tmp_path.glob("model_*.pt"))
    assert kept == [0, 3, 5, 6]  # the milestones 0 and 3, the newest two
