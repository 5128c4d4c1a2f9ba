"""A damaged ``policy.onnx`` is named in one line by every runner, not reported as a bug."""

from __future__ import annotations

import shutil

import pytest

from hybrid_recovery.cli.main import main
from hybrid_recovery.policy import OnnxPolicy
from hybrid_recovery.policy.shipped import SHIPPED_POLICY


@pytest.fixture
def damaged(tmp_path):
    if not (SHIPPED_POLICY / "policy.onnx").is_file():
        pytest.skip("no shipped policy")
    policy = tmp_path / "policy"
    shutil.copytree(SHIPPED_POLICY, policy)
    onnx = policy / "policy.onnx"
    onnx.write_bytes(onnx.read_bytes()[:5000])  # a copy cut short
    return policy


def test_a_damaged_network_is_named(damaged):
    with pytest.raises(ValueError) as info:
        OnnxPolicy(damaged)
    assert str(info.value) == (f"ONNX policy {damaged / 'policy.onnx'} is damaged or "
                               "unreadable (INVALID_PROTOBUF: Protobuf parsing failed.)")


def test_eval_names_a_damaged_network_and_writes_nothing(damaged, tmp_path, capsys):
    out = tmp_path / "eval"
    assert main(["eval", "--controller", f"onnx:{damaged}", "--trials", "1",
                 "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"error: ONNX policy {damaged / 'policy.onnx'} is damaged or unreadable "
        "(INVALID_PROTOBUF: Protobuf parsing failed.)\n")
    assert not out.exists()
