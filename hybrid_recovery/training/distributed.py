"""One training process among several: ``torchrun --nproc_per_node=N hybrid-recovery train``.

rsl-rl-lib's multi-GPU mode reads ``WORLD_SIZE``, ``RANK`` and ``LOCAL_RANK`` (set by
``torchrun``), joins a process group, broadcasts rank 0's weights and all-reduces the
gradients of every update (and the observation normalisers' statistics). Each process
simulates its own ``num_envs`` worlds, on ``cuda:<LOCAL_RANK>`` over NCCL or, with
``--device cpu``, on the CPU over gloo (the same collectives: several processes of one
machine or of several). This module gives each its device and seed, joins CPU processes
over gloo, and decides that only rank 0 writes the run directory (settings, checkpoints,
TensorBoard logs).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

import torch


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


def process_rank(environ: Mapping[str, str] = os.environ) -> Rank:
    """This process's :class:`Rank` from ``torchrun``'s environment (one process without it).

    Raises:
        ValueError: ranks outside ``WORLD_SIZE``.
    """
    world = int(environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return Rank()
    rank, local = int(environ.get("RANK", "0")), int(environ.get("LOCAL_RANK", "0"))
    if not (0 <= rank < world and 0 <= local < world):
        raise ValueError(f"RANK {rank} and LOCAL_RANK {local} must be in [0, {world})")
    return Rank(world, rank, local)


def join_cpu_group(rank: Rank) -> dict:
    """Joins this CPU process to the others' gloo process group (rsl-rl's multi-GPU mode
    joins GPUs over NCCL only); returns rsl-rl's ``multi_gpu`` settings of the rank."""
    torch.distributed.init_process_group(backend="gloo", rank=rank.rank,
                                         world_size=rank.world_size)
    return {"global_rank": rank.rank, "local_rank": rank.local_rank,
            "world_size": rank.world_size}
