"""A trial rendered to an MP4 with the balance overlay (CoM, ξ, support polygons)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import RECORD_DT, run_trial
from hybrid_recovery.files import atomic_path
from hybrid_recovery.sim.divergence import SimulationDiverged
from hybrid_recovery.sim.terrain import parse_terrain


def render_trial(controller, scenario: Scenario, path: str | Path, seconds: float | None = None,
                 fps: int = 25, model_path: str | None = None) -> Path:
    """Runs ``scenario`` with ``controller`` and writes its video to ``path``.

    Drawn with OpenGL where a context can be made, else in software
    (:func:`hybrid_recovery.sim.render.renderer_backend` says which).

    Raises:
        SimulationDiverged: the trial diverged; the video up to then is written.
    """
    import imageio.v2 as imageio

    from hybrid_recovery.sim.render import BalanceRenderer, balance_overlay

    every = max(1, round(1.0 / (fps * RECORD_DT)))
    renderer = BalanceRenderer(model_path, terrain=parse_terrain(scenario.terrain))
    frames: list = []
    count = [0]

    def grab(model, data, push) -> None:
        if count[0] % every == 0:
            frames.append(renderer.frame(data.qpos, balance_overlay(model, data, push), 1 / fps))
        count[0] += 1

    if seconds is not None:
        scenario = dataclasses.replace(scenario, duration=seconds)
    try:
        row = run_trial(controller, scenario, model_path, on_sample=grab)
    finally:
        renderer.close()
    path = Path(path)
    with atomic_path(path) as tmp:
        imageio.mimwrite(tmp, frames, fps=fps, macro_block_size=1)
    if row["diverged"]:
        raise SimulationDiverged(f"the simulation diverged ({row['divergence']}); the video "
                                 f"{path} stops there")
    return path
