"""Comparisons read from one plot per panel: every controller on it, with 95 % intervals.

:func:`overlay_figures` draws the sweep panels of the paper's Fig. 4 (§IV) with one line
(or bar group) per controller and 95 % Wilson intervals; :func:`difference_table` gives
each controller's success rate minus the first controller's, per force and direction,
with Newcombe's 95 % interval for a difference of two independent proportions (hybrid
Wilson score, "method 10").
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybrid_recovery.evaluation.scenario import SWEEP_DIRECTIONS  # noqa: E402
from hybrid_recovery.evaluation.success import wilson_interval  # noqa: E402
from hybrid_recovery.files import atomic_path  # noqa: E402

_DIRECTION_NAMES = {round(v, 4): k for k, v in SWEEP_DIRECTIONS.items()}


def rate_with_interval(rows: list[dict]) -> tuple[float, float, float, int, int]:
    """(p, lower, upper, successes, trials): success rate and its 95 % Wilson interval."""
    n = len(rows)
    k = sum(bool(r["success"]) for r in rows)
    lo, hi = wilson_interval(k, n)
    return (k / n if n else float("nan"), lo, hi, k, n)


def difference_interval(k1: int, n1: int, k2: int, n2: int) -> tuple[float, float, float]:
    """p1 − p2 with Newcombe's 95 % interval (from the two Wilson intervals).

    Returns:
        (d, lower, upper), each in [−1, 1].

    Raises:
        ValueError: a sample without trials.
    """
    if n1 <= 0 or n2 <= 0:
        raise ValueError("difference_interval needs trials in both samples")
    p1, p2 = k1 / n1, k2 / n2
    l1, u1 = wilson_interval(k1, n1)
    l2, u2 = wilson_interval(k2, n2)
    d = p1 - p2
    lower = d - float(np.hypot(p1 - l1, u2 - p2))
    upper = d + float(np.hypot(u1 - p1, p2 - l2))
    return d, max(-1.0, lower), min(1.0, upper)


def _by(rows: list[dict], key) -> dict:
    out: dict = defaultdict(list)
    for r in rows:
        out[key(r)].append(r)
    return dict(sorted(out.items()))


def _direction(r: dict) -> float:
    return round(float(r.get("direction", 0.0)), 4)


def _cell_name(force: float, direction: float) -> str:
    return f"{force:g} N {_DIRECTION_NAMES.get(direction, f'{direction:.2f} rad')}"


def difference_table(results: dict[str, list[dict]]) -> str:
    """Markdown: per (force, direction) cell and over all trials, each controller's
    successes / trials, then each other controller's rate minus the first's with its
    95 % interval (an interval excluding 0 is a difference the sample resolves)."""
    labels = list(results)
    base = labels[0]
    head = ["cell", *[f"{c} k/n" for c in labels], *[f"{c} − {base} [95 % CI]"
                                                   for c in labels[1:]]]
    lines = ["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
    cells: set[tuple[float, float]] = set()
    for rows in results.values():
        cells |= {(float(r["force"]), _direction(r)) for r in rows}
    keyed = {c: _by(rows, lambda r: (float(r["force"]), _direction(r)))
             for c, rows in results.items()}
    for cell in [*sorted(cells), None]:
        groups = {c: (results[c] if cell is None else keyed[c].get(cell, []))
                  for c in labels}
        name = "all" if cell is None else _cell_name(*cell)
        counts = {c: rate_with_interval(g)[3:] for c, g in groups.items()}
        row = [name, *[f"{k}/{n}" for k, n in counts.values()]]
        kb, nb = counts[base]
        for c in labels[1:]:
            k, n = counts[c]
            if n == 0 or nb == 0:
                row.append("–")
                continue
            d, lo, hi = difference_interval(k, n, kb, nb)
            row.append(f"{d:+.0%} [{lo:+.0%}, {hi:+.0%}]")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def _errorbar_line(ax, xs, rows_at, label, shift=0.0):
    stats = [rate_with_interval(rows_at[x]) for x in xs]
    rate = np.array([s[0] for s in stats])
    err = np.array([[s[0] - s[1] for s in stats], [s[2] - s[0] for s in stats]])
    ax.errorbar(np.asarray(xs) + shift, rate, yerr=err, marker="o", capsize=3, label=label)


def finish_panel(fig, ax, title: str, xlabel: str, ylabel: str, path: Path) -> None:
    """Titles, labels, grid and legend of one panel, saved to ``path`` and closed."""
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:  # a panel of one unnamed line has no legend
        ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def overlay_figures(results: dict[str, list[dict]], out: Path) -> list[tuple[str, str]]:
    """One PNG per panel of the sweep, one line (bar group) per controller, 95 % intervals;
    the lines are shifted sideways by 1.5 % of the axis per controller so that equal
    results stay visible.

    Panels: (A) success without push per pose; (B–C) success vs force; (D) mean recovery
    time vs force (successful trials, ±1.96 standard errors); (E) success vs direction;
    (F) success vs push height. Pushed panels pool the poses present in the results.

    Returns:
        (caption, file name) pairs, in panel order.
    """
    out.mkdir(parents=True, exist_ok=True)
    figs: list[tuple[str, str]] = []
    unpushed = {c: [r for r in rows if r["force"] == 0] for c, rows in results.items()}
    if any(unpushed.values()):
        poses = sorted({r["pose"] for rows in unpushed.values() for r in rows})
        fig, ax = plt.subplots(figsize=(5.5, 3.4))
        width = 0.8 / len(results)
        for j, (c, rows) in enumerate(unpushed.items()):
            by_pose = _by(rows, lambda r: r["pose"])
            stats = [rate_with_interval(by_pose.get(p, [])) for p in poses]
            rate = np.nan_to_num([s[0] for s in stats])
            err = np.array([[s[0] - s[1] for s in stats], [s[2] - s[0] for s in stats]])
            ax.bar(np.arange(len(poses)) + j * width, rate, width,
                   yerr=np.nan_to_num(err), capsize=3, label=c)
        ax.set_xticks(np.arange(len(poses)) + 0.4 - width / 2, poses)
        ax.set_ylim(0, 1.05)
        finish_panel(fig, ax, "(A) recovery without push", "start pose", "success rate",
                out / "overlay_A_no_push.png")
        figs.append(("(A) success without push, per pose (95 % CI)", "overlay_A_no_push.png"))
    panels = [("force", "(B–C) success vs force", "push force [N]", "BC_force", False),
              ("force", "(D) recovery time vs force", "push force [N]", "D_time", True),
              ("direction", "(E) success vs push direction", "push direction", "E_direction",
               False),
              ("height", "(F) success vs push height", "push height above the CoM [m]",
               "F_height", False)]
    for key, title, xlabel, stem, times in panels:
        fig, ax = plt.subplots(figsize=(5.5, 3.6))
        every = sorted({_direction(r) if key == "direction" else float(r.get(key, 0.0))
                        for rows in results.values() for r in rows})
        step = 0.015 * (every[-1] - every[0]) if len(every) > 1 else 0.0
        drawn = False
        for j, (c, rows) in enumerate(results.items()):
            shift = (j - (len(results) - 1) / 2) * step  # side by side, not on top
            source = rows if key == "force" else [r for r in rows if r["force"] > 0]
            rows_at = _by(source, _direction if key == "direction" else
                          (lambda r, k=key: float(r.get(k, 0.0))))
            xs = list(rows_at)
            if not xs:
                continue
            drawn = True
            if times:
                _time_line(ax, xs, rows_at, c, shift)
            else:
                _errorbar_line(ax, xs, rows_at, c, shift)
        if not drawn:  # e.g. no pushes on the poses protocol: no empty panel
            plt.close(fig)
            continue
        if key == "direction":
            shown = sorted({_direction(r) for rows in results.values() for r in rows
                            if r["force"] > 0})
            ax.set_xticks(shown, [_DIRECTION_NAMES.get(d, f"{d:.2f}") for d in shown])
        if not times:
            ax.set_ylim(-0.02, 1.05)
        finish_panel(fig, ax, title, xlabel, "mean recovery time [s]" if times else "success rate",
                out / f"overlay_{stem}.png")
        figs.append((f"{title} (95 % intervals)", f"overlay_{stem}.png"))
    return figs


def _time_line(ax, xs, rows_at, label, shift=0.0):
    pts = []
    for x in xs:
        times = np.array([r["recovery_time"] for r in rows_at[x] if r["success"]], dtype=float)
        if len(times):
            half = 1.96 * times.std(ddof=1) / np.sqrt(len(times)) if len(times) > 1 else 0.0
            pts.append((x, float(times.mean()), half))
    if pts:
        x, mean, half = (np.array(v) for v in zip(*pts, strict=True))
        ax.errorbar(x + shift, mean, yerr=half, marker="o", capsize=3, label=label)
