"""What the controllers report each tick, and the strategy labels they log."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np


class Strategy(IntEnum):
    """Balance strategy of a tick, ordered by escalation (an episode reports its max)."""

    STAND = 0
    """ξ near ξ_ref: quiet standing."""
    ANKLE = 1
    """The CoP moves inside the support polygon."""
    HIP = 2
    """The CMP leaves the support polygon through a centroidal angular momentum rate."""
    STEP = 3
    """A capture step is under way or has been taken."""
    NOT_APPLICABLE = 4
    """The robot is down (low CoM, non-foot contact or large tilt): no balance control."""


class Capturability(IntEnum):
    """How the LIP can still be captured, best first (0-step ... none)."""

    ZERO_STEP = 0
    """ξ ∈ C: the ankle strategy suffices."""
    HIP = 1
    """ξ outside C but within the hip strategy's reach."""
    ONE_STEP = 2
    """A single step into the 1-step capture region captures."""
    N_STEP = 3
    """Only within the N-step capture distance d_N (N = ``SteppingConfig.max_steps``)."""
    NONE = 4
    """Not capturable by ankle, hip or steps, or the robot is down."""


@dataclass
class TickDiagnostics:
    """One tick of the balance controller.

    Attributes:
        time: Simulation time [s].
        applicable: False when the robot is down (the QP is not run).
        reason: Why not applicable ("" when applicable).
        strategy: The tick's :class:`Strategy`.
        capturability: The tick's :class:`Capturability`.
        phase: ``"double_support"``, ``"swing_left"`` or ``"swing_right"``.
        capture_point: ξ, shape (2,) [m].
        cop: Commanded CoP, shape (2,) [m].
        cmp: Commanded CMP, shape (2,) [m].
        margin: −d(ξ, C): > 0 inside the support polygon [m].
        com: CoM c, shape (3,) [m]. com_vel: ċ, shape (3,) [m/s].
        qp_status: ``"solved"``, ``"relaxed"``, ``"last_good"``, ``"damping"`` or
            ``"not_applicable"``.
        solve_time: proxsuite time [s].
        qp_iterations: proxsuite iterations of the accepted solve.
        tick_time: Whole tick time (state, tasks, QP) [s].
        steps: Steps taken since reset.
    """

    time: float
    applicable: bool
    reason: str
    strategy: Strategy
    capturability: Capturability
    phase: str
    capture_point: np.ndarray = field(default_factory=lambda: np.zeros(2))
    cop: np.ndarray = field(default_factory=lambda: np.zeros(2))
    cmp: np.ndarray = field(default_factory=lambda: np.zeros(2))
    margin: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    com_vel: np.ndarray = field(default_factory=lambda: np.zeros(3))
    qp_status: str = "not_applicable"
    solve_time: float = 0.0
    qp_iterations: int = 0
    tick_time: float = 0.0
    steps: int = 0


@dataclass
class Event:
    """A logged decision: a step, a touchdown, a fallback, a hand-over.

    Attributes:
        time: Simulation time [s].
        kind: Short tag, e.g. ``"step"``, ``"touchdown"``, ``"fallback"``, ``"to_policy"``.
        message: Human-readable detail.
    """

    time: float
    kind: str
    message: str
