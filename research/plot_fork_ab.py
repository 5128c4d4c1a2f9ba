"""Forks of one checkpoint compared at equal env steps: the rise levels of each run.

Each run continues the same checkpoint (iteration ``--since`` − 1) with other settings;
for each pose with recorded rises it draws against env steps since the fork the level
k / K (``rise_level/<pose>``) and the stand-up share of the pose's training episodes
(``pose_stood_up/<pose>``), means of ``--block`` iterations, one line per run, and
prints a Markdown table of each run's iterations since the fork, the highest level and
the mean level of the last ``--block`` iterations that every run has logged.

    python research/plot_fork_ab.py control=runs/rises_fork teacher=runs/teacher_fork \\
        --since 13951 --out fork_ab.png
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from plot_rise_pace import block_means

from hybrid_recovery.training.record import read_scalars


def fork_table(runs: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]], since: int,
               block: int) -> list[dict]:
    """Rows (run, pose, iterations, top, level at the common end) of each run and pose.

    ``iterations``: logged iterations from ``since`` on; ``top``: the highest level
    among them; ``common``: the mean level over the last ``block`` iterations up to the
    last iteration that every run logged.

    Raises:
        ValueError: a run without rise levels from ``since`` on.
    """
    ends = []
    for label, scalars in runs.items():
        logged = [s[s >= since] for t, (s, _) in scalars.items() if t.startswith("rise_level/")]
        if not logged or not max(len(s) for s in logged):
            raise ValueError(f"{label}: no rise_level/<pose> logged from iteration {since} on")
        ends.append(min(int(s.max()) for s in logged))
    end = min(ends)
    rows = []
    for label, scalars in runs.items():
        for tag in sorted(t for t in scalars if t.startswith("rise_level/")):
            steps, level = scalars[tag]
            keep = steps >= since
            last = keep & (steps <= end) & (steps > end - block)
            rows.append({"run": label, "pose": tag.split("/", 1)[1],
                         "iterations": int(keep.sum()), "top": float(level[keep].max()),
                         "common_end": end, "common": float(level[last].mean())})
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="LABEL=RUN_DIR, one per fork")
    p.add_argument("--since", type=int, required=True, help="the forks' first iteration")
    p.add_argument("--block", type=int, default=10, help="iterations per plotted mean")
    p.add_argument("--out", type=Path, required=True, help="the PNG")
    args = p.parse_args()
    dirs = dict(item.split("=", 1) for item in args.runs)
    runs = {label: read_scalars(Path(d)) for label, d in dirs.items()}
    meta = json.loads((Path(next(iter(dirs.values()))) / "config.json").read_text())
    levels = int(meta["env_config"]["rises"]["levels"])
    per_iteration = meta["train_config"]["num_envs"] * meta["train_config"]["num_steps_per_env"]
    rows = fork_table(runs, args.since, args.block)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    poses = sorted({row["pose"] for row in rows})
    fig, axes = plt.subplots(2, len(poses), figsize=(6 * len(poses), 7), squeeze=False)
    for k, (label, scalars) in enumerate(runs.items()):
        for j, pose in enumerate(poses):
            for i, tag in enumerate((f"rise_level/{pose}", f"pose_stood_up/{pose}")):
                if tag not in scalars:
                    continue
                steps, values = scalars[tag]
                keep = steps >= args.since
                x, y = block_means(steps[keep], values[keep], args.block)
                axes[i, j].plot((x - args.since) * per_iteration / 1e6,
                                y / levels if i == 0 else y, color=f"C{k}", lw=1.2, label=label)
    for j, pose in enumerate(poses):
        axes[0, j].set_title(pose)
        axes[0, j].set_ylabel(f"rise level k / K (K = {levels})")
        axes[1, j].set_ylabel("stand-up share of the pose's episodes")
        axes[1, j].set_xlabel(f"M env steps since iteration {args.since}")
        for ax in axes[:, j]:
            ax.set_ylim(-0.02, 1.02)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=70)
    print("| run | pose | iterations | highest level | level at the common end |")
    print("|---|---|---|---|---|")
    for row in rows:
        print(f"| {row['run']} | {row['pose']} | {row['iterations']} | {row['top']:.0f} | "
              f"{row['common']:.1f} at {row['common_end']} |")


if __name__ == "__main__":
    main()
