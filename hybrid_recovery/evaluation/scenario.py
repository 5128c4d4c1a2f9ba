"""Evaluation scenarios and the protocols that enumerate them (paper §IV-A)."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from hybrid_recovery.sim.initial_states import POSES

SWEEP_POSES = ("standing", "squatting", "kneeling", "supine", "sitting")
SWEEP_FORCES = tuple(float(f) for f in range(0, 501, 50))
"""[N]."""
SWEEP_DIRECTIONS = {"front": 0.0, "back": np.pi, "left": np.pi / 2, "right": -np.pi / 2}
"""Push directions relative to the robot's heading [rad]."""
SWEEP_HEIGHTS = (-0.2, 0.0, 0.2, 0.4, 0.6)
"""Push application height relative to the CoM [m]."""
PUSH_NOISE = 0.25
"""Initialisation-noise scale of push trials (see :class:`Scenario`)."""


@dataclass(frozen=True)
class Scenario:
    """One trial: initial pose, an optional torso push, a seed.

    Attributes:
        pose: initial pose name.
        force: push magnitude [N] (0: no push).
        direction: push direction in the robot's heading frame [rad] (0 = forward).
        height: push point height relative to the CoM [m].
        push_time: push start [s]; push_duration [s].
        duration: trial length [s].
        seed: initial-state noise seed.
        noise: scale of the paper's initialisation noise (base ±0.05 m, ±0.2 rad, joints
            ±0.1 rad): 1 for recovery from randomised poses, 0.25 for push tests, whose
            robot starts standing still.
    """

    pose: str
    force: float = 0.0
    direction: float = 0.0
    height: float = 0.0
    push_time: float = 1.0
    push_duration: float = 0.1
    duration: float = 20.0
    seed: int = 0
    noise: float = 1.0

    @property
    def key(self) -> str:
        """A stable identifier (used to resume an interrupted protocol)."""
        return (f"{self.pose}|{self.force:g}|{self.direction:.4f}|{self.height:g}|"
                f"{self.push_time:g}|{self.push_duration:g}|{self.duration:g}|{self.seed}|"
                f"{self.noise:g}")

    def to_dict(self) -> dict:
        return asdict(self)


def poses_protocol(trials: int, seed: int = 0, poses: tuple[str, ...] = SWEEP_POSES,
                   duration: float = 20.0) -> list[Scenario]:
    """``trials`` recoveries from randomised initial poses (paper: 10,000), no push."""
    rng = np.random.default_rng(seed)
    picks = rng.integers(len(poses), size=trials)
    return [Scenario(poses[p], duration=duration, seed=seed * 1_000_003 + i)
            for i, p in enumerate(picks)]


def sweep_protocol(trials_per_cell: int = 1, seed: int = 0,
                   poses: tuple[str, ...] = SWEEP_POSES,
                   forces: tuple[float, ...] = SWEEP_FORCES,
                   directions: tuple[str, ...] = tuple(SWEEP_DIRECTIONS),
                   heights: tuple[float, ...] = SWEEP_HEIGHTS,
                   duration: float = 20.0) -> list[Scenario]:
    """The sim-to-sim grid: poses × forces × directions × heights × k trials."""
    out = []
    for pose, force, direction, height, k in itertools.product(
            poses, forces, directions, heights, range(trials_per_cell)):
        out.append(Scenario(pose, force, SWEEP_DIRECTIONS[direction], height,
                            duration=duration, seed=seed * 1_000_003 + k, noise=PUSH_NOISE))
    return out


def pushes_protocol(trials_per_force: int = 1, seed: int = 0,
                    forces: tuple[float, ...] = SWEEP_FORCES[1:],
                    directions: tuple[str, ...] = tuple(SWEEP_DIRECTIONS),
                    duration: float = 6.0) -> list[Scenario]:
    """Standing push hierarchy: pushes at the CoM height, 0.1 s, each direction."""
    return [Scenario("standing", force, SWEEP_DIRECTIONS[d], 0.0, duration=duration,
                     seed=seed * 1_000_003 + k, noise=PUSH_NOISE)
            for force, d, k in itertools.product(forces, directions, range(trials_per_force))]


PROTOCOLS: dict[str, Callable[..., list[Scenario]]] = {
    "poses": poses_protocol, "sweep": sweep_protocol, "pushes": pushes_protocol}
"""Protocol name → scenario generator."""


def check_pose(pose: str) -> None:
    if pose not in POSES:
        raise ValueError(f"unknown pose '{pose}': choose one of {list(POSES)}")
