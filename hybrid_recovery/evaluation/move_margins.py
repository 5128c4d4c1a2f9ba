"""The static margin table along each move (``hybrid-recovery getup margins``).

Each move runs from a noisy evaluation start (the paper's initialisation noise, §IV) of
the pose it serves, on the torque-controlled H1-2 (dt 2 ms, 1× effort limits, targets
within 0.9× ranges), with the state checked every 0.1 s
(:func:`hybrid_recovery.getup.margins.margins_along`). ``to_front`` starts from the
supine start turned a quarter onto its left side (no evaluation pose starts on a side).
"""

from __future__ import annotations

import csv
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import start_state
from hybrid_recovery.files import atomic_path, atomic_write
from hybrid_recovery.getup.margins import MarginSample, PhaseMargins, margins_along, summarise
from hybrid_recovery.getup.moves import ALL_MOVES
from hybrid_recovery.getup.single_move import SingleMove
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.initial_states import quat_mul, seat_single

MOVE_STARTS: dict[str, str] = {
    "lie_back": "sitting", "roll": "supine", "to_front": "supine", "tuck": "prone",
}
"""The evaluation pose each move starts from (``to_front``: turned onto its side)."""


def _check_move(name: str) -> None:
    if name not in ALL_MOVES:
        raise ValueError(f"unknown move '{name}': use one of {sorted(ALL_MOVES)}")


def _turn_onto_side(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    """Turns the whole robot 90° about its spine, the left side down."""
    mujoco.mj_kinematics(model, data)
    spine = data.xmat[model.body(constants.TORSO_BODY).id].reshape(3, 3)[:, 2].copy()
    turn = np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn, spine, np.pi / 2)
    data.qpos[3:7] = quat_mul(turn[None], data.qpos[None, 3:7])[0]


def move_start(model: mujoco.MjModel, move: str, seed: int) -> mujoco.MjData:
    """The noisy start ``move`` runs from (:data:`MOVE_STARTS`), seated on the floor.

    Raises:
        ValueError: an unknown move.
    """
    _check_move(move)
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario(MOVE_STARTS.get(move, "sitting"), seed=seed), None,
                               "default")
    if move == "to_front":
        _turn_onto_side(model, data)
    seat_single(model, data)
    mujoco.mj_forward(model, data)
    return data


def move_margins(moves: list[str] | tuple[str, ...] | None = None,
                 seeds: list[int] | tuple[int, ...] = (0,), every: float = 0.1) -> list[dict]:
    """Executes each move from its start, once per seed, and checks its states.

    Args:
        moves: Move names (None: every move of :data:`~hybrid_recovery.getup.moves.ALL_MOVES`).
        seeds: Seeds of the noisy starts.
        every: Sampling period [s].

    Returns:
        Per move and seed: ``{"move", "seed", "start", "start_state", "events",
        "arrived", "samples", "phases"}`` (``start``: the evaluation pose,
        ``start_state``: the ground state it settled in) with the
        :class:`~hybrid_recovery.getup.margins.MarginSample` list and its
        :class:`~hybrid_recovery.getup.margins.PhaseMargins` summary.

    Raises:
        ValueError: an unknown move, no seed, or a negative seed.
    """
    names = list(ALL_MOVES) if moves is None else list(moves)
    for name in names:
        _check_move(name)
    if len(seeds) == 0:
        raise ValueError("name at least one seed")
    for seed in seeds:
        if seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {seed}")
    model = load_torque_model()
    out = []
    for name in names:
        for seed in seeds:
            data = move_start(model, name, seed)
            single = SingleMove(name)
            samples = margins_along(model, data, single, every=every)
            out.append({"move": name, "seed": seed, "start": MOVE_STARTS.get(name, "sitting"),
                        "events": [(round(e.time, 2), e.kind, e.message)
                                   for e in single.events],
                        "start_state": single.start_state,
                        "arrived": single.status == "arrived", "samples": samples,
                        "phases": summarise(samples)})
    return out


def _row(p: PhaseMargins) -> str:
    margin = "—" if np.isnan(p.min_margin) else f"{p.min_margin:+.2f}"
    why = p.reason or "—"
    if p.dynamic:
        why += " (dynamic by design)"
    return (f"| {p.phase} | {p.samples} | {100 * p.feasible_fraction:.0f} % | {margin} | "
            f"{p.max_leftover_force:.0f} N, {p.max_leftover_moment:.0f} N·m | {why} |")


def _by_move(results: list[dict]) -> dict[str, list[dict]]:
    groups: dict[str, list[dict]] = {}
    for result in results:
        groups.setdefault(result["move"], []).append(result)
    return groups


def margin_table(results: list[dict]) -> str:
    """The margin table (Markdown): per move, how many runs reached its end state and the
    states their starts settled in; per phase, over the states of every run, the states
    checked, the fraction statically feasible, the least margin 1 − ρ over the supported
    ones, the largest unbalanced wrench over the unsupported ones and the most frequent
    reason the rest are not feasible."""
    lines = ["| move/phase | states | statically feasible | min margin 1 − ρ | "
             "largest unbalanced wrench | where not feasible |",
             "|---|---|---|---|---|---|"]
    for move, runs in _by_move(results).items():
        settled = dict.fromkeys(r["start_state"] for r in runs)
        counts = ", ".join(f"{state} {sum(r['start_state'] == state for r in runs)}"
                           for state in settled)
        seeds = " ".join(str(r["seed"]) for r in runs)
        lines.append(f"| **{move}** from {runs[0]['start']} starts (seeds {seeds}; settled "
                     f"{counts}) | | | | | {ALL_MOVES[move].end} reached "
                     f"{sum(r['arrived'] for r in runs)}/{len(runs)} |")
        lines += [_row(p) for p in summarise([s for r in runs for s in r["samples"]])]
    return "\n".join(lines)


CSV_FIELDS = ("move", "seed", "time", "phase", "dynamic", "feasible", "supported", "margin",
              "leftover_force", "leftover_moment", "contacts", "unmapped", "reason")
"""Columns of :func:`write_csv` (time [s], margin 1 − ρ [-], force [N], moment [N·m])."""


def write_csv(results: list[dict], path: str | Path) -> Path:
    """Every checked state, one row each (:data:`CSV_FIELDS`), written atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)

    def write(f) -> None:
        writer = csv.writer(f)
        writer.writerow(CSV_FIELDS)
        for result in results:
            s: MarginSample
            for s in result["samples"]:
                writer.writerow([result["move"], result["seed"], f"{s.time:.3f}", s.phase,
                                 int(s.dynamic), int(s.feasible), int(s.supported),
                                 f"{s.margin:.4f}", f"{s.leftover_force:.2f}",
                                 f"{s.leftover_moment:.2f}",
                                 " ".join(s.contacts), " ".join(s.unmapped), s.reason])

    atomic_write(path, "w", write)
    return path


def plot_margins(results: list[dict], path: str | Path) -> Path:
    """Margin 1 − ρ against time, one panel per move (every seed's states); unsupported
    states as red crosses at the bottom, dynamic phases shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = _by_move(results)
    fig, axes = plt.subplots(len(groups), 1, figsize=(7, 1.9 * len(groups)), squeeze=False)
    for ax, (move, runs) in zip(axes[:, 0], groups.items(), strict=True):
        samples: list[MarginSample] = [s for r in runs for s in r["samples"]]
        t = np.array([s.time for s in samples])
        margin = np.clip([s.margin for s in samples], -1.0, 1.0)
        ok = np.array([s.supported for s in samples], dtype=bool)
        ax.plot(t[ok], margin[ok], ".", ms=3, color="tab:blue", label="supported")
        ax.plot(t[~ok], np.full(int((~ok).sum()), -1.0), "x", ms=4, color="tab:red",
                label="unsupported")
        for s in samples:
            if s.dynamic:
                ax.axvspan(s.time - 0.05, s.time + 0.05, color="0.9", lw=0)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylim(-1.1, 1.05)
        ax.set_ylabel("1 − ρ")
        ax.set_title(f"{move} from {runs[0]['start']} starts ({len(runs)} seeds)", fontsize=9)
    axes[-1, 0].set_xlabel("time in the move [s]")
    axes[0, 0].legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80)
    plt.close(fig)
    return path
