"""The pace of the start-pose frontier along a lineage of runs, and where it would end.

Reads a fork and the runs it descends from (oldest first, :func:`load_lineage`) and, for
each bridge logged along it, fits a straight line to its level (``bridge_blend/<pose>`` ×
``bridge.levels``) over the iterations from ``--since`` on (a bridge added later: from
its own first logged iteration); the fit's slope says how many iterations, env steps and
hours of one training process (at the run's seconds per iteration over its last 500
iterations) the bridge would need to reach the target pose itself, if the pace held. A
bridge no longer in ``bridge.pairs`` is drawn up to its end, not estimated. The pull on
the starts of ``assist.poses`` (``curriculum/assist_fraction``) is annealed by
``assist.decay`` per advance; its advances over the same window give the same estimate
for the pull to reach ``assist.floor``. Writes a PNG and prints a Markdown table.

    python research/plot_frontier_pace.py runs/root runs/parent runs/fork --since 3600 \\
        --out frontier_pace.png
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from hybrid_recovery.training.record import load_lineage, logged_iterations


def fit_pace(steps: np.ndarray, values: np.ndarray, since: int) -> tuple[float, float]:
    """Least-squares line through (iteration, value) from ``since`` on: (slope, intercept)."""
    keep = steps >= since
    if keep.sum() < 2:
        raise ValueError(f"fewer than two logged iterations from {since} on")
    slope, intercept = np.polyfit(steps[keep].astype(float), values[keep], 1)
    return float(slope), float(intercept)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("lineage", nargs="+", type=Path, help="run directories, oldest first")
    p.add_argument("--since", type=int, required=True, help="first iteration of the fit")
    p.add_argument("--out", type=Path, required=True, help="the PNG")
    args = p.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scalars, ranges = load_lineage(args.lineage)
    meta = json.loads((args.lineage[-1] / "config.json").read_text())
    env, train = meta["env_config"], meta["train_config"]
    levels = int(env["bridge"]["levels"])
    per_iteration = train["num_envs"] * train["num_steps_per_env"]
    _, last = logged_iterations(scalars)
    times = [scalars[t] for t in ("Perf/collection_time", "Perf/learning_time") if t in scalars]
    recent = last - 499  # hours at the current pace of one process, not the window's
    seconds = sum(float(np.mean(v[s >= recent])) for s, v in times)

    fig, axes = plt.subplots(1, 2, figsize=(13, 4.2))
    rows = []
    current = {target for _, target in env["bridge"]["pairs"]}
    logged = sorted(t.split("/", 1)[1] for t in scalars if t.startswith("bridge_blend/"))
    for k, target in enumerate(logged):
        steps, blend = scalars[f"bridge_blend/{target}"]
        level = blend * levels
        start, end = max(args.since, int(steps.min())), int(steps.max())
        slope, intercept = fit_pace(steps, level, start)
        at_target = (levels - intercept) / slope if slope > 0 else math.inf
        ended = target not in current  # taken out of bridge.pairs: drawn to its end only
        rows.append((f"bridge to {target} " + (f"(ended at {end})" if ended
                                               else f"(level / {levels})"),
                     f"{level[steps >= end - 249].mean():.2f}", f"{slope * 1000:.3f} per 1000",
                     math.nan if ended else at_target - last))
        block = 50
        edges = np.arange(steps.min(), steps.max() + block, block)
        index = np.digitize(steps, edges)
        centres = [steps[index == i].mean() for i in np.unique(index)]
        means = [level[index == i].mean() for i in np.unique(index)]
        axes[0].plot(centres, means, color=f"C{k}", lw=1.2, label=f"{target} (mean of {block})")
        xs = np.array([start, end if ended else min(at_target, last + 40000)])
        axes[0].plot(xs, slope * xs + intercept, color=f"C{k}", ls="--", lw=1,
                     label=f"fit from {xs[0]:.0f}: {slope * 1000:.2f} levels / 1000 it")
    axes[0].axhline(levels, color="k", lw=0.8)
    axes[0].annotate(f"the target pose ({levels}/{levels})", (args.since, levels),
                     fontsize=8, va="bottom")
    axes[0].set_title("start-pose bridges along the lineage, with straight-line fits",
                      fontsize=9)
    axes[0].set_xlabel("iteration")
    axes[0].set_ylabel("bridge level")
    axes[0].legend(fontsize=7)
    axes[0].grid(alpha=0.3)

    steps, fraction = scalars["curriculum/assist_fraction"]
    axes[1].plot(steps, fraction, color="C2", lw=1.2)
    assist = env["assist"]
    window = last - args.since
    # advances over the window (not amendments: keep those before --since)
    decays = round(math.log(fraction[steps >= args.since][0] / fraction[-1])
                   / math.log(1.0 / assist["decay"]))
    needed = math.log(assist["floor"] / fraction[-1]) / math.log(assist["decay"])
    per_decay = window / decays if decays else math.inf
    rows.append((f"pull on {', '.join(assist['poses'])} (× m g)", f"{fraction[-1]:.3f}",
                 f"{decays} advances in {window} it", needed * per_decay))
    axes[1].axhline(assist["floor"], color="k", lw=0.8)
    axes[1].annotate(f"floor {assist['floor']}", (steps.min(), assist["floor"]), fontsize=8,
                     va="bottom")
    axes[1].set_title(f"the pull's fraction (× m g; decay ×{assist['decay']} per advance)",
                      fontsize=9)
    axes[1].set_xlabel("iteration")
    axes[1].grid(alpha=0.3)
    for ax in axes:
        for run in ranges[1:]:
            ax.axvline(run["first_iteration"], color="0.7", lw=0.6, ls=":")
    names = " → ".join(r["run"] for r in ranges)
    fig.suptitle(f"{names} (dotted: forks); {seconds:.1f} s per iteration, "
                 f"{per_iteration} env steps per iteration", fontsize=9)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    plt.close(fig)

    print(f"iterations {args.since}–{last}; {seconds:.1f} s per iteration of one process "
          f"(mean of {recent}–{last})")
    print("| frontier | now | pace | iterations to the end at that pace | env steps | hours |")
    print("|---|---|---|---|---|---|")
    for name, now, pace, left in rows:
        if math.isnan(left):
            print(f"| {name} | {now} | {pace} | – (the bridge ended) | – | – |")
        elif math.isinf(left):
            print(f"| {name} | {now} | {pace} | never | – | – |")
        else:
            print(f"| {name} | {now} | {pace} | {left:,.0f} | {left * per_iteration / 1e6:,.0f} M "
                  f"| {left * seconds / 3600:,.0f} |")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
