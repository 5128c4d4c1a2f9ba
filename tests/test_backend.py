"""The physics backend switch: its choices are checked before anything is built, with
exact messages (no MuJoCo Warp needed)."""

from __future__ import annotations

import builtins
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.sim.backend import WARP_INSTALL, check_backend


@pytest.mark.parametrize(("backend", "device", "message"), [
    ("mjx", "cpu", "unknown physics backend 'mjx'; known: ['batch', 'warp']"),
    ("batch", "tpu", "unknown device 'tpu'; known: ['cpu', 'cuda']"),
    ("batch", "cuda", "backend 'batch' (CPU MuJoCo) runs on the cpu device only; "
                      "use --backend warp for cuda"),
])
def test_bad_choices_are_refused_by_name(backend, device, message):
    with pytest.raises(ValueError) as err:
        check_backend(backend, device)
    assert str(err.value) == message


def test_env_refuses_an_unknown_backend_before_building():
    cfg = default_config()
    cfg.num_envs, cfg.backend = 2, "physx"
    with pytest.raises(ValueError, match=r"^unknown physics backend 'physx'; known: "):
        RecoveryEnv(cfg)


def test_warp_without_mujoco_warp_names_the_install_command(monkeypatch):
    real_import = builtins.__import__

    def no_warp(name, *args, **kwargs):
        if name in ("warp", "mujoco_warp"):
            raise ImportError(f"No module named '{name}'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_warp)
    with pytest.raises(ImportError) as err:
        check_backend("warp", "cpu")
    assert str(err.value) == ("backend 'warp' needs MuJoCo Warp: "
                              'pip install "mujoco-warp==4.0.0" "warp-lang==1.19.0"')
    assert WARP_INSTALL in str(err.value)



def test_the_gpu_check_script_refuses_a_machine_without_a_gpu(tmp_path):
    """``scripts/gpu_check.sh`` (the GPU figures in one run) stops at once, by name, where
    torch sees no CUDA GPU, and writes nothing."""
    if torch.cuda.is_available():
        pytest.skip("a CUDA GPU is present")
    script = Path(__file__).resolve().parents[1] / "scripts" / "gpu_check.sh"
    env = {"PATH": f"{Path(sys.executable).parent}:/usr/bin:/bin"}
    done = subprocess.run(["bash", str(script), str(tmp_path / "out")], env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1
    assert done.stderr.strip().splitlines()[-1] == \
        "gpu_check: no CUDA GPU (torch.cuda.is_available() is False)"
    assert not (tmp_path / "out").exists()
