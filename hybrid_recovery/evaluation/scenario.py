"""Evaluation scenarios and the protocols that enumerate them (paper §IV-A)."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace

import numpy as np

from hybrid_recovery.envs.terminations import SUCCESS_TIME
from hybrid_recovery.sim.initial_states import POSES
from hybrid_recovery.sim.terrain import parse_terrain

SWEEP_POSES = ("standing", "squatting", "kneeling", "supine", "sitting")
SWEEP_FORCES = tuple(float(f) for f in range(0, 501, 50))
"""[N]."""
SWEEP_DIRECTIONS = {"front": 0.0, "back": np.pi, "left": np.pi / 2, "right": -np.pi / 2}
"""Push directions relative to the robot's heading [rad]."""
SWEEP_HEIGHTS = (-0.2, 0.0, 0.2, 0.4, 0.6)
"""Push application height relative to the CoM [m]."""
PUSH_NOISE = 0.25
"""Initialisation-noise scale of push trials (see :class:`Scenario`)."""

MAX_PUSH_FORCE = 1000.0
"""The largest torso push a run accepts [N]: twice the sweep's largest. For 0.1 s it gives
the 67 kg robot 1.5 m/s, a certain fall; larger ones test the solver, not the controller
(at 1.5–2 kN a lying robot's simulation diverges, a joint above 10³ rad/s, even at the
sweep's heights)."""
PUSH_HEIGHT_RANGE = (-1.0, 1.0)
"""Push point heights a run accepts, relative to the CoM [m]: the robot's extent about its
standing CoM (0.92 m above the soles, 0.85 m below the top of the head)."""
MOTOR_STRENGTH_RANGE = (0.1, 2.0)
"""Motor strengths a run accepts: the fraction of the rated torque τ_lim the motors give."""
MAX_PAYLOAD = 60.0
"""The largest torso payload a run accepts [kg] (the robot's own mass is about 67 kg)."""
MAX_DELAY = 0.2
"""The largest added actuation delay a run accepts [s]."""
MAX_NOISE = 5.0
"""The largest initialisation-noise scale a run accepts: base tilts of ±1 rad, beyond
which a named start pose is no longer that pose."""


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
        terrain: the ground (:func:`~hybrid_recovery.sim.terrain.parse_terrain`), e.g.
            ``flat``, ``slope:10``, ``rough:5``, ``step:10``.
        motor_strength: the motors' torque bound as a fraction of the rated ±τ_lim.
        payload: a point mass at the torso's centre of mass [kg].
        delay: added actuation delay [s]: every controller's output (targets or torques)
            reaches the motors this long later, in whole physics steps.

    The last three change the simulated robot only: each controller keeps the nominal
    model (:mod:`hybrid_recovery.evaluation.off_nominal`).
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
    terrain: str = "flat"
    motor_strength: float = 1.0
    payload: float = 0.0
    delay: float = 0.0

    def __post_init__(self) -> None:
        """Refuses numbers a trial cannot run on (a push far out of
        :data:`MAX_PUSH_FORCE` is allowed here: it ends the trial as diverged).

        Raises:
            ValueError: ``duration must be a finite number > 0, got inf`` and the like.
        """
        for name in ("force", "direction", "height"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be a finite number, got {getattr(self, name)}")
        for name in ("push_time", "push_duration", "noise"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, "
                                 f"got {getattr(self, name)}")
        if not (np.isfinite(self.duration) and self.duration > 0.0):
            raise ValueError(f"duration must be a finite number > 0, got {self.duration}")
        for name, (low, high), unit in (("motor_strength", MOTOR_STRENGTH_RANGE, ""),
                                        ("payload", (0.0, MAX_PAYLOAD), " kg"),
                                        ("delay", (0.0, MAX_DELAY), " s")):
            value = getattr(self, name)
            if not (np.isfinite(value) and low <= value <= high):
                raise ValueError(f"{name} must be a finite number from {low:g} to "
                                 f"{high:g}{unit}, got {value}")
        if self.seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {self.seed}")
        parse_terrain(self.terrain)

    @property
    def min_duration(self) -> float:
        """The shortest trial that can show a recovery [s]: the end of the push (the start
        without one), then ``SUCCESS_TIME`` of standing."""
        end = self.push_time + self.push_duration if self.force > 0 else 0.0
        return end + SUCCESS_TIME

    @property
    def off_nominal(self) -> bool:
        """Weak motors, a payload or a delay."""
        return self.motor_strength != 1.0 or self.payload != 0.0 or self.delay != 0.0

    @property
    def key(self) -> str:
        """A stable identifier (used to resume an interrupted protocol); the terrain and the
        off-nominal robot are in it only where they are not nominal."""
        terrain = "" if self.terrain == "flat" else f"|{self.terrain}"
        robot = (f"|strength={self.motor_strength:g}|payload={self.payload:g}|"
                 f"delay={self.delay:g}" if self.off_nominal else "")
        return (f"{self.pose}|{self.force:g}|{self.direction:.4f}|{self.height:g}|"
                f"{self.push_time:g}|{self.push_duration:g}|{self.duration:g}|{self.seed}|"
                f"{self.noise:g}{terrain}{robot}")

    def to_dict(self) -> dict:
        return asdict(self)


def poses_protocol(trials: int, seed: int = 0, poses: tuple[str, ...] = SWEEP_POSES,
                   duration: float = 20.0) -> list[Scenario]:
    """``trials`` recoveries from randomised initial poses (paper: 10,000), no push."""
    rng = np.random.default_rng(seed)
    picks = rng.integers(len(poses), size=trials)
    return [Scenario(poses[p], duration=duration, seed=seed * 1_000_003 + i)
            for i, p in enumerate(picks)]


def cell_seed(seed: int, scenario: Scenario, k: int) -> int:
    """The start seed of trial ``k`` of a push cell: its own for every pose, force, height
    and push axis (front, back, lateral), so that the trials of a grid are independent
    and a cell draws the same starts whichever other cells run beside it. A left and a
    right push share the axis, hence the seed: the right one starts from the mirror image
    of the left one's state (:func:`hybrid_recovery.evaluation.trial.start_state`)."""
    axis = 2 if abs(np.sin(scenario.direction)) > 1e-9 else int(np.cos(scenario.direction) < 0)
    entropy = [seed, k, SWEEP_POSES.index(scenario.pose) if scenario.pose in SWEEP_POSES
               else len(SWEEP_POSES) + sorted(POSES).index(scenario.pose),
               round(scenario.force * 1000), axis, round(scenario.height * 1000) + 10**6]
    return int(np.random.SeedSequence(entropy).generate_state(1)[0])


def _push_cells(cells, trials: int, seed: int, duration: float) -> list[Scenario]:
    out = []
    for (pose, force, direction, height), k in itertools.product(cells, range(trials)):
        cell = Scenario(pose, force, SWEEP_DIRECTIONS[direction], height, duration=duration,
                        noise=PUSH_NOISE)
        out.append(replace(cell, seed=cell_seed(seed, cell, k)))
    return out


def sweep_protocol(trials_per_cell: int = 1, seed: int = 0,
                   poses: tuple[str, ...] = SWEEP_POSES,
                   forces: tuple[float, ...] = SWEEP_FORCES,
                   directions: tuple[str, ...] = tuple(SWEEP_DIRECTIONS),
                   heights: tuple[float, ...] = SWEEP_HEIGHTS,
                   duration: float = 20.0) -> list[Scenario]:
    """The sim-to-sim grid: poses × forces × directions × heights × k trials, each trial
    from its own start (:func:`cell_seed`)."""
    return _push_cells(itertools.product(poses, forces, directions, heights),
                       trials_per_cell, seed, duration)


def pushes_protocol(trials_per_force: int = 1, seed: int = 0,
                    forces: tuple[float, ...] = SWEEP_FORCES[1:],
                    directions: tuple[str, ...] = tuple(SWEEP_DIRECTIONS),
                    duration: float = 6.0) -> list[Scenario]:
    """Standing push hierarchy: pushes at the CoM height, 0.1 s, each direction, each
    trial from its own start (:func:`cell_seed`)."""
    return _push_cells(itertools.product(("standing",), forces, directions, (0.0,)),
                       trials_per_force, seed, duration)


TERRAIN_LADDER: tuple[str, ...] = ("flat", "slope:5", "slope:10", "slope:15", "rough:1",
                                   "rough:3", "rough:5", "step:3", "step:6", "step:10")
"""The terrain protocol's terrains: flat ground, then each kind at rising difficulty."""


def terrain_protocol(trials_per_cell: int = 1, seed: int = 0,
                     poses: tuple[str, ...] = SWEEP_POSES,
                     terrains: tuple[str, ...] = TERRAIN_LADDER,
                     duration: float = 20.0) -> list[Scenario]:
    """Recoveries from each pose on each terrain, k trials per cell, no push; trial k of a
    pose starts from the same state on every terrain (a paired comparison)."""
    return [Scenario(pose, duration=duration, terrain=terrain, seed=int(
                np.random.SeedSequence([seed, SWEEP_POSES.index(pose) if pose in SWEEP_POSES
                                        else len(SWEEP_POSES) + sorted(POSES).index(pose),
                                        k]).generate_state(1)[0]))
            for terrain, pose, k in itertools.product(terrains, poses, range(trials_per_cell))]


PROTOCOLS: dict[str, Callable[..., list[Scenario]]] = {
    "poses": poses_protocol, "sweep": sweep_protocol, "pushes": pushes_protocol,
    "terrain": terrain_protocol}
"""Protocol name → scenario generator."""


def check_pose(pose: str) -> None:
    if pose not in POSES:
        raise ValueError(f"unknown pose '{pose}': choose one of {list(POSES)}")
