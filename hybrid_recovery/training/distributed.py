"""One training process among several: ``torchrun --nproc_per_node=N hybrid-recovery train``.

rsl-rl-lib's multi-GPU mode reads ``WORLD_SIZE``, ``RANK`` and ``LOCAL_RANK`` (set by
``torchrun``), joins an NCCL process group, broadcasts rank 0's weights and all-reduces
the gradients of every update. Each process simulates its own ``num_envs`` worlds on
``cuda:<LOCAL_RANK>``; this module gives each its device and seed, and decides that only
rank 0 writes the run directory (settings, checkpoints, TensorBoard logs).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class Rank:
    """This process's place among ``world_size`` training processes."""

    world_size: int = 1
    rank: int = 0
    local_rank: int = 0
    """The GPU of this process on its machine."""

    @property
    def writes(self) -> bool:
        """Whether this process writes the run directory (rank 0 only)."""
        return self.rank == 0

    def seed(self, seed: int) -> int:
        """The process's seed: ``seed + rank``, so that ranks draw different episodes."""
        return seed + self.rank

    def learner_device(self, device: str) -> str:
        """The torch device of the policy and the PPO update: ``cpu`` or
        ``cuda:<local_rank>``."""
        return "cpu" if device == "cpu" else f"cuda:{self.local_rank}"


def process_rank(device: str, environ: Mapping[str, str] = os.environ) -> Rank:
    """This process's :class:`Rank` from ``torchrun``'s environment (one process without it).

    Raises:
        ValueError: several processes on the ``cpu`` device (rsl-rl's multi-GPU mode
            all-reduces over NCCL), or ranks outside ``WORLD_SIZE``.
    """
    world = int(environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return Rank()
    rank, local = int(environ.get("RANK", "0")), int(environ.get("LOCAL_RANK", "0"))
    if device != "cuda":
        raise ValueError(f"{world} training processes (WORLD_SIZE) need --device cuda: "
                         "rsl-rl's multi-GPU mode all-reduces gradients over NCCL")
    if not (0 <= rank < world and 0 <= local < world):
        raise ValueError(f"RANK {rank} and LOCAL_RANK {local} must be in [0, {world})")
    return Rank(world, rank, local)
