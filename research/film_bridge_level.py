"""Contact sheets of a run's actor at one level of a start-pose bridge: deterministic,
unassisted episodes as in ``probe_bridge_levels.py``, one row of frames per episode at the
given times, each seen from the robot's left (its heading at the start), with the CoM
(blue), the capture point (green) and the support polygons drawn in; a frame after the
episode's end is left grey. Drawn with OpenGL where a context can be made, else in
software.

    python research/film_bridge_level.py runs/my_run --at 4 --episodes 3 --out film.png
"""

from __future__ import annotations

from pathlib import Path

import hybrid_recovery  # noqa: F401  (first: it chooses MuJoCo's OpenGL backend)

# isort: split
import matplotlib
import matplotlib.pyplot as plt
import mujoco
import numpy as np
import torch
from bridge_args import bridge_parser

from hybrid_recovery.sim.render import BalanceRenderer, add_overlay, balance_overlay
from hybrid_recovery.training.probe import (
    bridge_env,
    ended_episodes,
    heading_xy,
    start_episodes,
)

matplotlib.use("Agg")

DEFAULT_TIMES = (0.0, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8, 1.0, 1.5, 2.0)


def record(run: Path, levels: int, level: int, episodes: int, seed: int, source: str,
           target: str, times: list[float]) -> dict:
    """qpos (episodes, frames, nq) of the first episode of each env at ``times`` [s] (NaN
    once it has ended), its start heading (episodes, 2) and how it ended."""
    env, actor, data = bridge_env(run, episodes, seed, levels, source, target)
    env.bridge.level[target] = level
    obs = start_episodes(env)
    heading = heading_xy(env.sims.bind("xmat")[:, 1].copy())
    at = [int(round(t / env.dt)) for t in times]
    frames = np.full((episodes, len(times), env.model.nq), np.nan)
    done, outcome = np.zeros(episodes, bool), ["running"] * episodes
    for step in range(max(at) + 1):
        for j in np.flatnonzero(np.array(at) == step):
            frames[~done, j] = env.qpos[~done]
        with torch.no_grad():
            obs, _, dones, extras = env.step(actor(obs))
        ended, up, causes = ended_episodes(dones, extras)
        for i, stood, cause in zip(ended, up, causes, strict=True):
            if not done[i]:
                how = "stood up" if stood else "ended: " + (cause or "?")
                outcome[i] = f"{how} at {(step + 1) * env.dt:.2f} s"
                done[i] = True
    return {"qpos": frames, "heading": heading, "outcome": outcome,
            "iteration": int(data["iter"])}


def sheet(film: dict, times: list[float], title: str, out: Path, size: int = 260) -> None:
    """Draws ``film`` (from :func:`record`) as a grid: episodes × times."""
    renderer = BalanceRenderer(width=size, height=size, distance=2.4, elevation=-10.0)
    rows, cols = film["qpos"].shape[:2]
    fig, axes = plt.subplots(rows, cols, figsize=(1.6 * cols, 1.75 * rows + 0.4), squeeze=False)
    blank = np.full((size, size, 3), 0.6)
    for i in range(rows):
        yaw = np.degrees(np.arctan2(film["heading"][i, 1], film["heading"][i, 0]))
        renderer.camera.azimuth = yaw - 90.0  # the camera on the robot's left
        for j in range(cols):
            ax = axes[i, j]
            q = film["qpos"][i, j]
            if np.isnan(q).any():
                ax.imshow(blank)
            else:
                renderer.data.qpos[:] = q
                overlay = balance_overlay(renderer.model, renderer.data)
                mujoco.mj_camlight(renderer.model, renderer.data)
                renderer.camera.lookat[:] = [overlay.com[0], overlay.com[1], 0.45]
                renderer.renderer.update_scene(renderer.data, renderer.camera)
                add_overlay(renderer.renderer.scene, overlay)
                ax.imshow(renderer.renderer.render())
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"{times[j]:.2f} s", fontsize=8)
        axes[i, 0].set_ylabel(film["outcome"][i], fontsize=6)
    renderer.close()
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = bridge_parser(__doc__.split("\n")[0])
    parser.add_argument("--at", type=int, required=True, help="the bridge level k (of K)")
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--times", type=float, nargs="+", default=list(DEFAULT_TIMES))
    parser.add_argument("--out", type=Path, required=True, help="PNG, one per run: RUN's "
                        "name is inserted before the suffix when there are several")
    args = parser.parse_args()
    if not 0 <= args.at <= args.levels:
        parser.error(f"--at must be in 0 … {args.levels}")
    torch.set_num_threads(1)
    for run in args.runs:
        film = record(run, args.levels, args.at, args.episodes, args.seed, args.source,
                      args.target, sorted(args.times))
        out = args.out if len(args.runs) == 1 else \
            args.out.with_name(f"{args.out.stem}_{run.name}{args.out.suffix}")
        sheet(film, sorted(args.times), f"{run.name} {film['iteration']}: {args.source} → "
              f"{args.target} at {args.at}/{args.levels}, deterministic, unassisted", out)
        print(f"{out}: " + "; ".join(film["outcome"]), flush=True)


if __name__ == "__main__":
    main()
