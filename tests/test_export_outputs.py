"""``hybrid-recovery export`` never overwrites an exported policy unasked (not even the
shipped one), replaces one whole with ``--force``, and an export that fails writes
nothing. Exports the checkpoint kept in ``training/checkpoints`` (no training logs: no
``curves.png``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from hybrid_recovery.cli.main import main
from hybrid_recovery.policy.shipped import SHIPPED_POLICY
from hybrid_recovery.training.export import export_policy

ROOT = Path(__file__).resolve().parents[1]
CHECKPOINT_RUN = ROOT / "training" / "checkpoints" / "recovery_model_rises_s0"


@pytest.fixture
def run_dir() -> Path:
    if not (CHECKPOINT_RUN / "latest.pt").is_file():
        pytest.skip(f"no checkpoint in {CHECKPOINT_RUN}")
    return CHECKPOINT_RUN


def _snapshot(directory: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


def _others(parent: Path, keep: str) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name != keep)


def test_an_existing_export_is_refused_and_kept(run_dir, tmp_path, capsys):
    out = tmp_path / "export"
    assert main(["export", str(run_dir), "--out", str(out)]) == 0
    before = _snapshot(out)
    capsys.readouterr()
    assert main(["export", str(run_dir), "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"error: {out} already holds an exported policy (policy.onnx, policy.json, "
        "training_record.json); pass --force to overwrite it\n")
    assert _snapshot(out) == before


def test_the_shipped_policy_is_not_overwritten_without_force(run_dir, tmp_path, capsys):
    shipped = tmp_path / "h1_2_recovery"  # a copy: the test must not touch the checkout
    shutil.copytree(SHIPPED_POLICY, shipped)
    before = _snapshot(shipped)
    assert main(["export", str(run_dir), "--out", str(shipped)]) == 2
    assert capsys.readouterr().err == (
        f"error: {shipped} already holds an exported policy (policy.onnx, policy.json, "
        "training_record.json, curves.png); pass --force to overwrite it\n")
    assert _snapshot(shipped) == before
    assert main(["export", str(run_dir), "--out", str(shipped), "--force"]) == 0
    after = _snapshot(shipped)
    assert "curves.png" not in after  # the earlier export's figure would not belong
    assert set(after) == {"policy.onnx", "policy.json", "training_record.json", "README.md"}
    assert after["README.md"] == before["README.md"]  # not an export's file: left alone
    record = json.loads(after["training_record.json"])
    assert record["iteration"] == json.loads(after["policy.json"])["provenance"]["iteration"]
    assert _others(tmp_path, "h1_2_recovery") == []


def test_an_export_that_fails_writes_nothing(run_dir, tmp_path, monkeypatch):
    import torch

    def broken(*args, **kwargs):
        raise RuntimeError("ONNX export failed")

    monkeypatch.setattr(torch.onnx, "export", broken)
    with pytest.raises(RuntimeError, match="^ONNX export failed$"):
        export_policy(run_dir, tmp_path / "new")
    assert list(tmp_path.iterdir()) == []
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "policy.json").write_text("{}")
    with pytest.raises(RuntimeError, match="^ONNX export failed$"):
        export_policy(run_dir, kept, force=True)
    assert _snapshot(kept) == {"policy.json": b"{}"} and _others(tmp_path, "kept") == []


def test_a_run_without_a_checkpoint_exports_nothing(tmp_path, capsys):
    empty = tmp_path / "run"
    empty.mkdir()
    assert main(["export", str(empty), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (f"error: no checkpoint in {empty} (no latest.pt, no "
                                       "model_*.pt)\n")
    assert _others(tmp_path, "run") == []
