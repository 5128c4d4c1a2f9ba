"""The CLI sets torch's OpenMP wait policy before torch loads, unless the user set one."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from hybrid_recovery.cli.main import OMP_WAIT_POLICY, main


def test_main_sets_passive_wait_policy(monkeypatch):
    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    with pytest.raises(SystemExit):
        main(["bench", "nonsense"])
    assert os.environ["OMP_WAIT_POLICY"] == OMP_WAIT_POLICY == "PASSIVE"


def test_main_keeps_the_users_wait_policy(monkeypatch):
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")
    with pytest.raises(SystemExit):
        main(["bench", "nonsense"])
    assert os.environ["OMP_WAIT_POLICY"] == "ACTIVE"


def test_torch_is_not_loaded_before_the_policy_is_set():
    """libgomp reads OMP_WAIT_POLICY once, when torch loads: the CLI module and every
    subcommand module must import without torch."""
    code = ("import sys; import hybrid_recovery.cli.main as m; m._register_all(); "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
