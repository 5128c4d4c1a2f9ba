"""Figures of the QP baseline: solve time per tick, and the standing push-recovery sweep.

Both print-and-return functions run single-threaded on the caller's machine; timings
depend on its load (report it with the figures).

* :func:`solve_timing` records every QP of a pushed episode and replays them with three
  solver set-ups: proxsuite dense with warm start (as the controller runs it), proxsuite
  dense cold (a new QP per tick) and ``qpsolvers.solve_qp(..., solver="proxqp")``.
* :func:`push_sweep` pushes the standing robot at the torso CoM for 0.1 s in ±x, ±y with
  forces 0–500 N, stepping off and on, and checks standing 3 s after the push (CoM
  height > 0.85 m, torso tilt < 72°, no non-foot contact). Results go row by row to a
  JSON-lines file when given, and rows already there are skipped (resumable).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.config import default_config
from hybrid_recovery.control.proxsuite_build import BUILD, proxsuite
from hybrid_recovery.control.rollout import Push, run_episode, standing_data
from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.control.wbc_qp import QpProblem

DIRECTIONS: dict[str, tuple[float, float]] = {"+x": (1.0, 0.0), "-x": (-1.0, 0.0),
                                              "+y": (0.0, 1.0), "-y": (0.0, -1.0)}
"""Push directions (world frame; +x forward, +y left)."""

PUSH_START = 0.5
"""Push onset [s] (the robot stands still before)."""
PUSH_DURATION = 0.1
"""Push duration [s]."""
_WARM_START = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
SETTLE_AFTER_PUSH = 3.0
"""Success is checked this long after the push ends [s]."""


def _stats(seconds: Iterable[float]) -> dict[str, float]:
    arr = np.asarray(list(seconds)) * 1e3
    return {"median_ms": float(np.median(arr)), "p99_ms": float(np.percentile(arr, 99)),
            "max_ms": float(arr.max()), "n": int(arr.size)}


def _replay_warm(problems: list[QpProblem]) -> list[float]:
    qps: dict[tuple[bool, bool], proxsuite.proxqp.dense.QP] = {}
    out = []
    for p in problems:
        n, n_eq, n_in = p.hessian.shape[0], p.a_eq.shape[0], p.c_in.shape[0]
        start = time.perf_counter()
        if p.stance not in qps:
            qp = proxsuite.proxqp.dense.QP(n, n_eq, n_in, True)
            qp.settings.initial_guess = _WARM_START
            qp.settings.eps_abs, qp.settings.eps_rel = 1e-5, 0.0
            qp.init(*p.args())
            qps[p.stance] = qp
        else:
            qps[p.stance].update(*p.args())
        qps[p.stance].solve()
        out.append(time.perf_counter() - start)
    return out


def _replay_cold(problems: list[QpProblem]) -> list[float]:
    out = []
    for p in problems:
        start = time.perf_counter()
        qp = proxsuite.proxqp.dense.QP(p.hessian.shape[0], p.a_eq.shape[0], p.c_in.shape[0],
                                       True)
        qp.settings.eps_abs, qp.settings.eps_rel = 1e-5, 0.0
        qp.init(*p.args())
        qp.solve()
        out.append(time.perf_counter() - start)
    return out


def _replay_qpsolvers(problems: list[QpProblem]) -> list[float]:
    import qpsolvers  # here: it loads proxsuite at import (proxsuite_build)

    out = []
    for p in problems:
        start = time.perf_counter()
        qpsolvers.solve_qp(p.hessian, p.gradient, np.vstack([p.c_in, -p.c_in]),
                           np.concatenate([p.upper, -p.lower]), p.a_eq, p.b_eq, p.box_lower,
                           p.box_upper, solver="proxqp", eps_abs=1e-5, eps_rel=0.0)
        out.append(time.perf_counter() - start)
    return out


def solve_timing(push_force: float = 300.0, duration: float = 2.0,
                 log: Callable[[str], None] = print) -> dict[str, dict[str, float]]:
    """Times the QP on the ticks of a standing episode with a forward push (and a step).

    Args:
        push_force: Forward torso push at t = 0.5 s for 0.1 s [N].
        duration: Simulated time [s] (one tick per 2 ms).
        log: Printer.

    Returns:
        {name: {median_ms, p99_ms, max_ms, n}} for ``live_solve`` (update + solve inside
        the controller), ``live_tick`` (the whole controller tick), and the replays
        ``proxsuite_dense_warm``, ``proxsuite_dense_cold``, ``qpsolvers_proxqp``.
    """
    model = load_torque_model()
    push = Push(np.array([push_force, 0.0, 0.0]), PUSH_START, PUSH_DURATION)
    controller = BalanceController()
    result = run_episode(model, controller, duration, keep_diagnostics=True, push=push)
    live = [d for d in result.diagnostics if d.applicable]
    # The same episode again with every QP recorded for the replays (recording copies
    # the problem inside the tick: kept out of the live figures above).
    recorded = BalanceController()
    problems: list[QpProblem] = []
    data = standing_data(model)
    recorded.reset(model, data)
    recorded.qp.recorder = problems  # kept across the episode's reset
    run_episode(model, recorded, duration, data=data, push=push)
    out = {"live_solve": _stats(d.solve_time for d in live),
           "live_tick": _stats(d.tick_time for d in live),
           "proxsuite_dense_warm": _stats(_replay_warm(problems)),
           "proxsuite_dense_cold": _stats(_replay_cold(problems)),
           "qpsolvers_proxqp": _stats(_replay_qpsolvers(problems))}
    n = max((p.hessian.shape[0] for p in problems), default=0)
    log(f"QP timing: {len(problems)} ticks, {push_force:.0f} N push, steps taken "
        f"{len(controller.steps)}; double-support QP: {n} variables; proxsuite build "
        f"{BUILD}")
    iters = np.array([d.qp_iterations for d in live])
    log(f"proxsuite iterations per tick: median {np.median(iters):.0f}, "
        f"p99 {np.percentile(iters, 99):.0f}, max {iters.max()}")
    log(f"{'':24s} {'median [ms]':>12s} {'p99 [ms]':>10s} {'max [ms]':>10s}")
    for name, s in out.items():
        log(f"{name:24s} {s['median_ms']:12.3f} {s['p99_ms']:10.3f} {s['max_ms']:10.3f}")
    return out


def push_trial(direction: str, force: float, stepping: bool) -> dict:
    """One push from standing; the row of :func:`push_sweep` (``diverged``: the
    simulation diverged, never standing)."""
    dx, dy = DIRECTIONS[direction]
    cfg = default_config()
    cfg.stepping.enabled = stepping
    controller = BalanceController(cfg)
    model = load_torque_model()
    push = Push(np.array([dx * force, dy * force, 0.0]), PUSH_START, PUSH_DURATION)
    result = run_episode(model, controller, PUSH_START + PUSH_DURATION + SETTLE_AFTER_PUSH,
                         push=push, stop_below=0.5)
    return {"direction": direction, "force": force, "stepping": stepping,
            "standing": bool(result.standing), "strategy": controller.max_strategy.name.lower(),
            "steps": sum(s.touchdown is not None for s in controller.steps),
            "fell": bool(controller.went_down),
            "fallbacks": sum(e.kind == "fallback" for e in controller.events),
            "diverged": result.divergence is not None}


def push_sweep(forces: Iterable[float] = range(0, 501, 50),
               directions: Iterable[str] = tuple(DIRECTIONS),
               stepping: Iterable[bool] = (False, True), results: str | Path | None = None,
               log: Callable[[str], None] = print) -> list[dict]:
    """The push-recovery sweep (see the module docstring); resumable through ``results``.

    Returns:
        One dict per (stepping, direction, force): standing, strategy, steps, fell,
        fallbacks, diverged.
    """
    rows: list[dict] = []
    done: dict[tuple, dict] = {}
    path = Path(results) if results is not None else None
    if path is not None and path.is_file():
        for line in path.read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                done[(row["stepping"], row["direction"], float(row["force"]))] = row
    for step in stepping:
        for direction in directions:
            for force in forces:
                key = (bool(step), direction, float(force))
                if key in done:
                    rows.append(done[key])
                    continue
                row = push_trial(direction, float(force), bool(step))
                rows.append(row)
                log(f"stepping {'on ' if step else 'off'} {direction} {force:5.0f} N: "
                    f"{'standing' if row['standing'] else 'FELL    '} {row['strategy']:6s} "
                    f"steps {row['steps']}")
                if path is not None:
                    with path.open("a") as f:
                        f.write(json.dumps(row) + "\n")
    return rows


def sweep_table(rows: list[dict]) -> str:
    """Highest force recovered per direction (all lower forces recovered too, or not)
    and the strategy at each force, stepping off and on."""
    lines = []
    for step in (False, True):
        sub = [r for r in rows if r["stepping"] == step]
        if not sub:
            continue
        forces = sorted({r["force"] for r in sub})
        lines.append(f"stepping {'on' if step else 'off'}")
        lines.append(f"{'dir':>4s} {'max [N]':>8s} " + " ".join(f"{f:>6.0f}" for f in forces))
        for direction in DIRECTIONS:
            cells = {r["force"]: r for r in sub if r["direction"] == direction}
            if not cells:
                continue
            ok = [f for f in forces if f in cells and cells[f]["standing"]]
            best = max(ok) if ok else float("nan")
            marks = []
            for f in forces:
                r = cells.get(f)
                if r is None:
                    marks.append(f"{'-':>6s}")
                elif r.get("diverged"):
                    marks.append(f"{'DIV':>6s}")
                else:
                    label = {"stand": "stand", "ankle": "ankle", "hip": "hip", "step": "step"}[
                        r["strategy"]]
                    marks.append(f"{(label if r['standing'] else 'X' + label[:4]):>6s}")
            lines.append(f"{direction:>4s} {best:8.0f} " + " ".join(marks))
        lines.append("")
    lines.append("cells: strategy used (X = fell, with the last strategy tried; DIV = the "
                 "simulation diverged)")
    return "\n".join(lines)
