"""The pace of the recorded-rise starts (``rises.*``) along a run, per pose.

For each pose with recorded rises, draws against env steps since the rises came in (the
first iteration that logged ``rise_level/<pose>``): its level k / K, the share of the way
from the hand-over back to the ground pose that its starts have moved, with a straight
line fitted from ``--since``; and the stand-up share of the training episodes that start
from each pose (``pose_stood_up/<pose>``, stochastic policy, means of ``--block``
iterations). ``--old-pace`` draws, for comparison, a frontier moving that share per 1000
iterations (the blend bridges of docs/experiments.md §4–6: 1/16). Prints a Markdown table
of each pose's level, pace and the iterations, env steps and hours to K at that pace
(hours: of one process, at the run's mean seconds per iteration since ``--since``).
Levels are read as logged, over the run's current ``rises.levels``: where a run amended
``rises.levels``, start ``--since`` after the amendment.

    python research/plot_rise_pace.py runs/rises_fork --since 12651 --old-pace 0.0625 \\
        --out rise_pace.png
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from hybrid_recovery.training.record import load_lineage


def block_means(steps: np.ndarray, values: np.ndarray, block: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Means of ``values`` over consecutive blocks of ``block`` iterations: (centres,
    means), one per block that holds a logged iteration."""
    index = (steps - steps.min()) // block
    keys = np.unique(index)
    return (np.array([steps[index == i].mean() for i in keys]),
            np.array([values[index == i].mean() for i in keys]))


def rise_pace(scalars: dict[str, tuple[np.ndarray, np.ndarray]], levels: int, since: int
              ) -> dict[str, dict[str, float]]:
    """Per pose with ``rise_level/<pose>``: ``first`` (its first logged iteration), ``now``
    (the mean level k over its last 25 logged iterations), ``slope`` [levels per
    iteration] of a least-squares line through (iteration, k) from ``since`` on,
    ``left``: iterations from the last one to k = K at that slope (inf when it does not
    rise; 0 once at K), ``top`` (the highest level logged) and ``top_since`` (the first
    iteration that logged it): a level that stalls shows as a ``top_since`` far back,
    which the straight line does not.

    Raises:
        ValueError: no rise levels logged, or fewer than two iterations from ``since``.
    """
    poses = sorted(t.split("/", 1)[1] for t in scalars if t.startswith("rise_level/"))
    if not poses:
        raise ValueError("the run logged no rise_level/<pose> (rises.files not set?)")
    out = {}
    for pose in poses:
        steps, level = scalars[f"rise_level/{pose}"]
        keep = steps >= since
        if keep.sum() < 2:
            raise ValueError(f"rise_level/{pose}: fewer than two logged iterations from "
                             f"{since} on")
        slope, intercept = np.polyfit(steps[keep].astype(float), level[keep], 1)
        now = float(level[-25:].mean())
        at_end = (levels - intercept) / slope if slope > 0 else math.inf
        left = 0.0 if now >= levels else max(at_end - float(steps.max()), 0.0)
        top = float(level.max())
        out[pose] = {"first": int(steps.min()), "now": now, "slope": float(slope),
                     "left": left, "top": top,
                     "top_since": int(steps[np.argmax(level >= top - 1e-9)])}
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("lineage", nargs="+", type=Path, help="run directories, oldest first")
    p.add_argument("--since", type=int, default=0, help="first iteration of the fit")
    p.add_argument("--block", type=int, default=25, help="iterations per plotted mean")
    p.add_argument("--old-pace", type=float, default=None,
                   help="a reference frontier's share of the way per 1000 iterations")
    p.add_argument("--out", type=Path, required=True, help="the PNG")
    args = p.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scalars, _ = load_lineage(args.lineage)
    meta = json.loads((args.lineage[-1] / "config.json").read_text())
    levels = int(meta["env_config"]["rises"]["levels"])
    train = meta["train_config"]
    per_iteration = train["num_envs"] * train["num_steps_per_env"]
    pace = rise_pace(scalars, levels, args.since)
    start = min(row["first"] for row in pace.values())
    times = [scalars[t] for t in ("Perf/collection_time", "Perf/learning_time") if t in scalars]
    seconds = sum(float(np.mean(v[s >= args.since])) for s, v in times)

    def m_steps(iterations: np.ndarray) -> np.ndarray:
        return (iterations - start) * per_iteration / 1e6

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for k, (pose, row) in enumerate(pace.items()):
        steps, level = scalars[f"rise_level/{pose}"]
        axes[0].plot(m_steps(steps), level / levels, color=f"C{k}", lw=1.2, label=pose)
        fit = np.array([max(args.since, row["first"]), steps.max()], float)
        axes[0].plot(m_steps(fit), (row["slope"] * (fit - fit[0]) + level[steps >= fit[0]][0])
                     / levels, color=f"C{k}", ls="--", lw=0.8,
                     label=f"{pose} fit: {row['slope'] * 1000 / levels:.3f} per 1000 it")
        if f"pose_stood_up/{pose}" in scalars:
            s, v = scalars[f"pose_stood_up/{pose}"]
            s, v = s[s >= start], v[s >= start]
            centres, means = block_means(s, v, args.block)
            axes[1].plot(m_steps(centres), means, color=f"C{k}", lw=1.2, label=pose)
    if args.old_pace is not None:
        end = max(float(scalars[f"rise_level/{p}"][0].max()) for p in pace)
        its = np.array([start, end])
        axes[0].plot(m_steps(its), (its - start) * args.old_pace / 1000, color="k", ls=":",
                     lw=1, label=f"reference: {args.old_pace:g} per 1000 it")
    axes[0].set_ylim(-0.02, 1.02)
    axes[0].set_title(f"rise starts: level k / K (K = {levels}); 0 = hand-over, "
                      "1 = the pose itself", fontsize=9)
    axes[0].set_ylabel("share of the way to the ground pose")
    axes[1].set_ylim(-0.02, 1.02)
    axes[1].set_title(f"stand-up share of the training episodes from each pose "
                      f"(means of {args.block} it)", fontsize=9)
    for ax in axes:
        ax.set_xlabel("M env steps since the rise starts came in")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.suptitle(f"{' → '.join(d.name for d in args.lineage)}: from iteration {start}, "
                 f"{per_iteration} env steps per iteration", fontsize=9)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=80)
    plt.close(fig)

    print(f"iterations {start}–{max(int(scalars[f'rise_level/{p}'][0].max()) for p in pace)}; "
          f"{seconds:.1f} s per iteration of one process since {args.since}")
    print("| pose | level now | highest, first reached at | pace | iterations to K at that pace "
          "| env steps | hours |")
    print("|---|---|---|---|---|---|---|")
    for pose, row in pace.items():
        left = row["left"]
        tail = ("never | – | –" if math.isinf(left) else
                f"{left:,.0f} | {left * per_iteration / 1e6:,.0f} M | "
                f"{left * seconds / 3600:,.1f}")
        print(f"| {pose} | {row['now']:.2f} / {levels} | {row['top']:.2f} at {row['top_since']} | "
              f"{row['slope'] * 1000:.2f} levels per 1000 it | {tail} |")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
