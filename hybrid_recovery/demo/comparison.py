"""The main job: a short side-by-side comparison of the shipped controllers.

Scenarios: pushes while standing (100, 200, 300 N forward, 200 N sideways), a fall-inducing
450 N push, and stand-ups from kneeling and supine. Controllers: ``zero`` (PD holding the
default pose), the QP balance baseline and the model-based half (QP plus ground moves)
when available, and the shipped learned policy (``models/policies/h1_2_recovery``) with
the hybrid (ground moves, policy, QP) when it is shipped.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from hybrid_recovery.controllers import make
from hybrid_recovery.evaluation.report import write_report
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.policy import SHIPPED_POLICY, is_shipped

DEMO_SCENARIOS: dict[str, Scenario] = {
    "push 100 N forward": Scenario("standing", 100.0, 0.0, duration=4.0, noise=0.25),
    "push 200 N forward": Scenario("standing", 200.0, 0.0, duration=4.0, noise=0.25),
    "push 300 N forward": Scenario("standing", 300.0, 0.0, duration=4.0, noise=0.25),
    "push 200 N left": Scenario("standing", 200.0, np.pi / 2, duration=4.0, noise=0.25),
    "push 450 N (fall)": Scenario("standing", 450.0, 0.0, duration=10.0, noise=0.25),
    "stand up from kneeling": Scenario("kneeling", duration=10.0, noise=0.5),
    "stand up from supine": Scenario("supine", duration=20.0, noise=0.5),
}


def available_controllers() -> tuple[list[str], list[str]]:
    """(controller specs to run, notes on what is missing)."""
    specs, notes = ["zero"], []
    try:
        make("qp")
        specs += ["qp", "model"]
    except ValueError as err:
        notes.append(f"QP baseline not available: {err}")
    if is_shipped():
        specs.append("learned")
        if "qp" in specs:
            specs.append("hybrid")
    else:
        notes.append(f"No trained policy is shipped yet (no policy.onnx in {SHIPPED_POLICY}): "
                     "the learned and hybrid controllers are left out.")
    return specs, notes


def run_demo(out_dir: str | Path = "results/demo", video: bool = True,
             controllers: Sequence[str] | None = None) -> Path:
    """Runs every scenario with every available controller (or with ``controllers``,
    registry specs); prints a table, writes the report (with the capture-point figure of
    the 200 N push) and one short video.

    Raises:
        ValueError: a spec of ``controllers`` the registry does not build (before any
            trial runs).
    """
    if controllers:
        specs, notes = list(controllers), list[str]()
        for spec in specs:
            make(spec)
    else:
        specs, notes = available_controllers()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for note in notes:
        print(f"note: {note}")
    results: dict[str, list[dict]] = {}
    traces = {}
    start = time.time()
    for spec in specs:
        controller = make(spec)
        label = _label(spec)
        rows = []
        for name, scenario in DEMO_SCENARIOS.items():
            row = run_trial(controller, scenario, record=name == "push 200 N forward")
            if "trace" in row:
                traces[label] = (row.pop("trace"), scenario.push_time)
            row["scenario"] = name
            rows.append(row)
        results[label] = rows
        print(f"  {label}: done ({time.time() - start:.0f} s)")
    print(_table(results))
    md = "\n".join(f"*{n}*" for n in notes)
    report = write_report(results, out, "hybrid_recovery demo: controllers side by side",
                          cp_traces=traces, notes=md + "\n\n" + _table(results),
                          sweep_plots=False)
    if video:
        _video(specs[-1], out)
    print(f"report: {report}")
    return report


def _label(spec: str) -> str:
    kind, _, _ = spec.partition(":")
    return {"learned": "learned policy", "onnx": "learned policy",
            "hybrid": "hybrid (moves + policy + QP)", "qp": "QP baseline",
            "model": "model-based (QP + ground moves)",
            "zero": "PD hold (zero action)"}[kind]


def _table(results: dict[str, list[dict]]) -> str:
    labels = list(results)
    lines = ["| scenario | " + " | ".join(labels) + " |", "|---" * (len(labels) + 1) + "|"]
    for i, name in enumerate(DEMO_SCENARIOS):
        cells = []
        for label in labels:
            r = results[label][i]
            if r.get("not_applicable"):
                cells.append("n/a")
            elif r["success"]:
                cells.append(f"✓ {r['recovery_time']:.1f} s ({r['strategy']})")
            else:
                cells.append(f"✗ ({r['strategy']})")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _video(spec: str, out: Path) -> None:
    try:
        from hybrid_recovery.evaluation.video import render_trial
        from hybrid_recovery.sim.render import renderer_backend
    except ImportError as err:
        print(f"note: no video ({err})")
        return
    scenario = DEMO_SCENARIOS["push 450 N (fall)" if spec.startswith(("learned", "onnx", "hybrid"))
                               else "push 200 N forward"]
    try:
        path = render_trial(make(spec), scenario, out / "demo.mp4", seconds=6.0)
        print(f"video: {path} (renderer: {renderer_backend()})")
    except Exception as err:  # keep the report; say why there is no video
        print(f"note: no video ({type(err).__name__}: {err})")
