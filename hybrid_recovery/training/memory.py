"""The memory a training run's environments need, checked before any is built.

A batch of N simulations allocates N MuJoCo data structures at once (and the rollout
storage holds N × T transitions); a number far beyond the machine's memory would sit in
the allocation for minutes and end in the kernel's out-of-memory kill, so it is refused
first, with the figure.
"""

from __future__ import annotations

from pathlib import Path

import mujoco

from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.robot import constants

ARENA_SHARE = 0.03
"""Share of MuJoCo's per-simulation arena (``mjModel.narena``: contacts, constraints,
stack) that a robot lying, rising and falling touches: on the project's H1-2 the
environment's resident memory grew by 0.51 MB per environment over 50 control steps from
the start poses, of which 0.06 MB is the data buffer, against a 15.7 MB arena."""
class NotEnoughMemory(RuntimeError):
    """A run's environments would not fit in the machine's available memory."""


ROLLOUT_COPIES = 3
"""The rollout's transitions are held in the storage, gathered into mini-batches and
passed through the networks: about three copies."""


def bytes_per_env(model: mujoco.MjModel, num_steps_per_env: int) -> tuple[int, int]:
    """(simulation, rollout) bytes of one environment: MuJoCo's data buffer plus the
    touched share of its arena, and ``num_steps_per_env`` transitions of float32
    observations (actor and critic), actions with their mean and std, and scalars."""
    data = mujoco.MjData(model)
    simulation = int(data.nbuffer + ARENA_SHARE * model.narena)
    floats = 2 * ACTOR_OBS_DIM + 32 + 3 * constants.NUM_JOINTS + 8
    return simulation, int(ROLLOUT_COPIES * 4 * floats * num_steps_per_env)


def available_memory(meminfo: str | Path = "/proc/meminfo") -> int | None:
    """``MemAvailable`` in bytes; None where the file does not say."""
    try:
        for line in Path(meminfo).read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{n:.0f} B"
        n /= 1000
    raise AssertionError


def check_num_envs(num_envs: int, model: mujoco.MjModel, num_steps_per_env: int,
                   available: int | None = None) -> None:
    """Refuses ``num_envs`` environments that do not fit in the available memory.

    Args:
        available: bytes (default: :func:`available_memory`; unknown: no check).

    Raises:
        NotEnoughMemory: ``--num-envs N needs about X of memory (Y per environment: ...);
            Z is available``.
    """
    available = available_memory() if available is None else available
    if available is None:
        return
    simulation, rollout = bytes_per_env(model, num_steps_per_env)
    need = num_envs * (simulation + rollout)
    if need > available:
        raise NotEnoughMemory(
            f"--num-envs {num_envs} needs about {_size(need)} of memory "
            f"({_size(simulation + rollout)} per environment: the simulation "
            f"{_size(simulation)}, the rollout {_size(rollout)}); {_size(available)} is "
            f"available")
