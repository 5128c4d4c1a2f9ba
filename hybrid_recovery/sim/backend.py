"""The physics backend of the batched environment: CPU MuJoCo's ``mujoco.batch.Batch`` or
MuJoCo Warp (:class:`~hybrid_recovery.sim.warp_batch.WarpBatch`), behind one interface.

Both hold N worlds of one model and give the environment (N, …) numpy arrays of the
simulation state and of per-world model values for its resets; MuJoCo Warp also gives
torch views of its device arrays, which the control steps read and write. The MDP is
written once.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import mujoco
import numpy as np
from mujoco import batch as mjbatch

BACKENDS = ("batch", "warp")
"""``batch``: CPU MuJoCo (float64, threads); ``warp``: MuJoCo Warp (float32, CPU or GPU)."""
DEVICES = ("cpu", "cuda")

WARP_INSTALL = 'pip install "mujoco-warp==4.0.0" "warp-lang==1.19.0"'
"""The command that installs the warp backend (the ``warp`` extra of the package)."""


class PhysicsBatch(Protocol):
    """The calls of ``mujoco.batch.Batch`` the environment makes."""

    nsim: int

    def bind(self, name: str) -> np.ndarray: ...
    def expand(self, name: str) -> np.ndarray: ...
    def step(self, ids: Sequence[int] | np.ndarray | None = None, nstep: int = 1,
             stage: int = ...) -> None: ...
    def forward(self, ids: Sequence[int] | np.ndarray | None = None,
                stage: int = ...) -> None: ...
    def reset(self, ids: Sequence[int] | np.ndarray | None = None,
              stage: int = ...) -> None: ...
    def set_const(self, ids: Sequence[int] | np.ndarray | None = None) -> None: ...
    def get_model(self, sim: int, model: mujoco.MjModel | None = None) -> mujoco.MjModel: ...
    def get_data(self, sim: int, data: mujoco.MjData | None = None) -> mujoco.MjData: ...


def check_backend(backend: str, device: str) -> None:
    """Checks a backend and device choice before anything is built.

    Raises:
        ValueError: an unknown backend or device, or ``cuda`` with the CPU backend.
        ImportError: ``warp`` without MuJoCo Warp installed (naming :data:`WARP_INSTALL`).
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown physics backend '{backend}'; known: {list(BACKENDS)}")
    if device not in DEVICES:
        raise ValueError(f"unknown device '{device}'; known: {list(DEVICES)}")
    if backend == "batch" and device != "cpu":
        raise ValueError("backend 'batch' (CPU MuJoCo) runs on the cpu device only; "
                         "use --backend warp for cuda")
    if backend == "warp":
        try:
            import mujoco_warp  # noqa: F401
            import warp
        except ImportError:
            raise ImportError(f"backend 'warp' needs MuJoCo Warp: {WARP_INSTALL}") from None
        if device == "cuda" and warp.get_cuda_device_count() == 0:
            raise ValueError("device 'cuda' needs a CUDA GPU, and Warp finds none")


def physics_batch(model: mujoco.MjModel, nsim: int, nthread: int = 0, backend: str = "batch",
                  device: str = "cpu", expand: Sequence[str] = (),
                  local_rank: int = 0) -> PhysicsBatch:
    """``nsim`` persistent worlds of ``model`` on the chosen backend.

    Args:
        nthread: CPU threads of the ``batch`` backend (0: all cores).
        expand: model fields given per-world values (the ``warp`` backend allocates
            them here; ``batch`` expands on first use).
        local_rank: the process's GPU under ``torchrun`` (``cuda:<local_rank>``).
    """
    check_backend(backend, device)
    if backend == "batch":
        return mjbatch.Batch(model, nsim, nthread, persistent=True)
    from hybrid_recovery.sim.warp_batch import WarpBatch

    return WarpBatch(model, nsim, "cpu" if device == "cpu" else f"cuda:{local_rank}", expand)
