"""The static check along a move: the feasibility QP on the states a move passes through.

A move is executed in MuJoCo (:class:`hybrid_recovery.getup.single_move.SingleMove`: the
executor's interpolation and joint PD, 1× effort limits, targets within 0.9× ranges);
every ``every`` seconds of the move the state q and the named floor contacts MuJoCo
reports (:func:`hybrid_recovery.getup.contact_map.floor_contacts`) go to the static
feasibility QP (:func:`hybrid_recovery.getup.feasibility.static_feasibility`). Each
sample records whether the state could be held still on those contacts, its worst
torque-limit margin 1 − ρ (ρ = max_j |τ_j| / τ_max,j) and, where no contact forces hold
the base, the wrench they leave unbalanced. Velocities are ignored: a state that is
moving may be held only dynamically, which the check reports as unsupported.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.dynamics.robot_model import GRAVITY, RobotModel
from hybrid_recovery.getup.contact_map import floor_contacts
from hybrid_recovery.getup.feasibility import FeasibilityConfig, static_feasibility
from hybrid_recovery.getup.move_executor import MOVING
from hybrid_recovery.getup.single_move import SingleMove
from hybrid_recovery.sim.divergence import SimulationDiverged, divergence


@dataclass(frozen=True)
class MarginSample:
    """The static check of one state.

    Attributes:
        time: Time since the move started [s].
        phase: ``<move>/<keyframe>`` of the phase in progress.
        dynamic: The phase is dynamic by design (:class:`~hybrid_recovery.getup.moves.Phase`).
        contacts: Named floor contacts MuJoCo reports.
        unmapped: Touching geoms no named contact covers (their support is not counted).
        feasible: Supported and ρ ≤ 1 at 1× effort limits.
        supported: Some contact forces in the friction pyramids hold the base.
        margin: 1 − ρ at the optimum [-] (negative: over a limit); for an unsupported
            state that of the best-supporting forces.
        leftover_force: |force| the contacts leave unbalanced [N] (0 when supported).
        leftover_moment: |moment about the CoM| they leave unbalanced [N·m].
        reason: Empty when feasible, else why not.
    """

    time: float
    phase: str
    dynamic: bool
    contacts: tuple[str, ...]
    unmapped: tuple[str, ...]
    feasible: bool
    supported: bool
    margin: float
    leftover_force: float
    leftover_moment: float
    reason: str


def state_margin(robot: RobotModel, model: mujoco.MjModel, data: mujoco.MjData,
                 phase: str = "", dynamic: bool = False, time: float = 0.0,
                 config: FeasibilityConfig | None = None) -> MarginSample:
    """The static check of ``data``'s state on the contacts MuJoCo reports.

    Args:
        robot: Dynamics of ``model``'s robot.
        model: Compiled model of the H1-2 on a floor.
        data: A forwarded state.
        phase, dynamic, time: Labels copied into the sample.
        config: Settings of the QP; defaults (μ 0.7, 1× limits) when None.
    """
    contacts, unmapped = floor_contacts(model, data)
    weight = robot.mass * GRAVITY
    if not contacts:
        return MarginSample(time, phase, dynamic, contacts, unmapped, False, False, 0.0,
                            weight, 0.0, "no named contact touches the floor")
    try:
        check = static_feasibility(robot, data.qpos.copy(), contacts, config)
    except ValueError as err:
        return MarginSample(time, phase, dynamic, contacts, unmapped, False, False, 0.0,
                            weight, 0.0, str(err))
    return MarginSample(time, phase, dynamic, contacts, unmapped, check.feasible,
                        check.supported, 1.0 - check.worst_ratio,
                        float(np.linalg.norm(check.leftover_wrench[:3])),
                        float(np.linalg.norm(check.leftover_wrench[3:])), check.reason)


def margins_along(model: mujoco.MjModel, data: mujoco.MjData, moves: SingleMove,
                  every: float = 0.1, timeout: float = 20.0,
                  config: FeasibilityConfig | None = None) -> list[MarginSample]:
    """Executes ``moves`` from ``data`` (torque model: ``ctrl`` = τ) and checks the state
    every ``every`` seconds while the move runs.

    Args:
        model: Torque-controlled model of the H1-2 on a floor.
        data: Start state; advanced in place to the move's end.
        moves: The move to execute (reset here).
        every: Sampling period [s].
        timeout: Simulated time after which the execution stops [s].
        config: Settings of the QP.

    Returns:
        The samples in time order (after the settle time, while a phase runs).

    Raises:
        ValueError: ``every`` or ``timeout`` not > 0.
        SimulationDiverged: the simulation diverged
            (:func:`~hybrid_recovery.sim.divergence.divergence`).
    """
    for name, value in (("every", every), ("timeout", timeout)):
        if not value > 0.0:
            raise ValueError(f"{name} must be > 0, got {value}")
    robot = RobotModel(model)
    moves.reset(model, data)
    t_end = float(data.time) + timeout
    next_sample, start = -1.0, -1.0
    samples: list[MarginSample] = []
    while data.time < t_end - 1e-9 and moves.status == MOVING:
        data.ctrl[:] = moves(model, data)
        if moves.move is not None:
            if start < 0.0:
                start = next_sample = float(data.time)
            if data.time >= next_sample - 1e-9:
                mujoco.mj_forward(model, data)
                phase = moves.move.phases[moves.phase]
                samples.append(state_margin(robot, model, data,
                                            f"{moves.move.name}/{phase.keyframe}",
                                            phase.dynamic, float(data.time) - start, config))
                next_sample += every
        t = float(data.time)
        mujoco.mj_step(model, data)
        if (why := divergence(data)) is not None:  # MuJoCo reset it: the rest means nothing
            raise SimulationDiverged(f"the simulation diverged at t = "
                                     f"{t + model.opt.timestep:.3f} s during the move ({why})")
    return samples


@dataclass(frozen=True)
class PhaseMargins:
    """The static check over one phase of a move.

    Attributes:
        phase: ``<move>/<keyframe>``.
        dynamic: Dynamic by design.
        samples: States checked.
        feasible_fraction: Fraction of them statically feasible [-].
        min_margin: Least 1 − ρ over the supported states [-] (NaN: none supported).
        max_leftover_force: Largest unbalanced force over the unsupported states [N].
        max_leftover_moment: Largest unbalanced moment over them [N·m].
        contacts: The contact sets met, most frequent first.
        reason: The most frequent reason of infeasibility (empty: always feasible).
    """

    phase: str
    dynamic: bool
    samples: int
    feasible_fraction: float
    min_margin: float
    max_leftover_force: float
    max_leftover_moment: float
    contacts: tuple[tuple[str, ...], ...]
    reason: str


def _most_frequent(items: list) -> list:
    counts: dict = {}
    for item in items:
        counts[item] = counts.get(item, 0) + 1
    return sorted(counts, key=lambda k: -counts[k])


def _short_reason(reason: str) -> str:
    """"base unsupported", "over the 1× effort limits: <worst joint>" or the reason."""
    head, _, rest = reason.partition(": ")
    if head.startswith("over the"):
        return f"{head}: {rest.split(' by ')[0]}"
    return head


def summarise(samples: list[MarginSample]) -> list[PhaseMargins]:
    """Per phase, in the order the phases ran: :class:`PhaseMargins`."""
    order = list(dict.fromkeys(s.phase for s in samples))
    out = []
    for phase in order:
        rows = [s for s in samples if s.phase == phase]
        supported = [s.margin for s in rows if s.supported]
        loose = [s for s in rows if not s.supported]
        reasons = _most_frequent([_short_reason(s.reason) for s in rows if not s.feasible])
        out.append(PhaseMargins(
            phase, rows[0].dynamic, len(rows),
            sum(s.feasible for s in rows) / len(rows),
            min(supported) if supported else float("nan"),
            max((s.leftover_force for s in loose), default=0.0),
            max((s.leftover_moment for s in loose), default=0.0),
            tuple(_most_frequent([s.contacts for s in rows])),
            reasons[0] if reasons else ""))
    return out
