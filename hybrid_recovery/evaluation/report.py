"""Markdown reports with the paper's figures (paper §IV) from evaluation results."""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybrid_recovery.dynamics.support import support_polygon  # noqa: E402
from hybrid_recovery.evaluation.overlay import (  # noqa: E402
    difference_table,
    finish_panel,
    overlay_figures,
)
from hybrid_recovery.evaluation.scenario import SWEEP_DIRECTIONS  # noqa: E402
from hybrid_recovery.evaluation.success import wilson_interval  # noqa: E402
from hybrid_recovery.files import atomic_path, atomic_write_text  # noqa: E402

_DIRECTION_NAMES = {round(v, 4): k for k, v in SWEEP_DIRECTIONS.items()}


def _rate(rows: list[dict], key: str = "success") -> tuple[float, float, float, int]:
    """Share of ``rows`` whose ``key`` is true, its 95 % Wilson interval, and the count."""
    n = len(rows)
    k = sum(bool(r.get(key)) for r in rows)
    lo, hi = wilson_interval(k, n)
    return (k / n if n else float("nan"), lo, hi, n)


def _diverged(rows: list[dict]) -> int:
    """How many of ``rows`` diverged (:func:`~hybrid_recovery.evaluation.trial.run_trial`)."""
    return sum(bool(r.get("diverged")) for r in rows)


def _group(rows: list[dict], *keys: str) -> dict[tuple, list[dict]]:
    out: dict[tuple, list[dict]] = defaultdict(list)
    for r in rows:
        out[tuple(r[k] for k in keys)].append(r)
    return dict(sorted(out.items()))


def summary_table(rows: list[dict], by: str = "pose") -> str:
    """Markdown table: success rate with 95 % CI and recovery times, per ``by``; the
    trials whose simulation diverged count as failures and are counted apart."""
    lines = [f"| {by} | trials | success | 95 % CI | mean t_rec [s] | median t_rec [s] | "
             "falls | stuck low | diverged |", "|---|---|---|---|---|---|---|---|---|"]
    for (value,), group in _group(rows, by).items():
        rate, lo, hi, n = _rate(group)
        times = [r["recovery_time"] for r in group if r["success"]]
        mean = f"{np.mean(times):.2f}" if times else "–"
        median = f"{np.median(times):.2f}" if times else "–"
        falls = sum(r["fell"] for r in group)
        stuck = [r["stuck_low"] for r in group if "stuck_low" in r]  # older results lack it
        stuck_rate = f"{np.mean(stuck):.1%}" if stuck else "–"
        lines.append(f"| {value} | {n} | {rate:.1%} | [{lo:.1%}, {hi:.1%}] | {mean} | {median} "
                     f"| {falls} | {stuck_rate} | {_diverged(group)} |")
    return "\n".join(lines)


def strategy_table(rows: list[dict]) -> str:
    """Markdown table of the push hierarchy: force × direction → success and strategy."""
    directions = sorted({round(r["direction"], 4) for r in rows})
    names = [_DIRECTION_NAMES.get(d, f"{d:.2f} rad") for d in directions]
    lines = ["| force [N] | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for (force,), group in _group(rows, "force").items():
        cells = []
        for d in directions:
            sub = [r for r in group if round(r["direction"], 4) == d]
            if not sub:
                cells.append("–")
                continue
            rate = _rate(sub)[0]
            label = Counter(r["strategy"] for r in sub).most_common(1)[0][0]
            cells.append(f"{rate:.0%} {label}")
        lines.append(f"| {force:g} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def comparison_table(results: dict[str, list[dict]],
                     provenance: dict[str, dict] | None = None) -> str:
    """Markdown table, one row per controller: its training provenance (variant,
    iteration, env steps) where known, then success and stuck-low rates over all its
    trials with 95 % CIs: the ablation's figures at deployment settings; then the falls
    and the trials whose simulation diverged."""
    provenance = provenance or {}
    lines = ["| controller | variant | iteration | env steps [M] | trials | success | "
             "95 % CI | stuck low | 95 % CI | falls | diverged |", "|---" * 11 + "|"]
    for label, rows in results.items():
        prov = provenance.get(label) or {}
        steps = prov.get("env_steps")
        succ, stuck = _rate(rows), _rate(rows, "stuck_low")
        cells = [label, prov.get("variant", "–"), prov.get("iteration", "–"),
                 "–" if steps is None else f"{steps / 1e6:.1f}", len(rows),
                 f"{succ[0]:.1%}", f"[{succ[1]:.1%}, {succ[2]:.1%}]",
                 f"{stuck[0]:.1%}", f"[{stuck[1]:.1%}, {stuck[2]:.1%}]",
                 sum(bool(r["fell"]) for r in rows), _diverged(rows)]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    return "\n".join(lines)


def stuck_low_figure(results: dict[str, list[dict]], provenance: dict[str, dict],
                     path: Path) -> bool:
    """Stuck-low rate over all trials against the policy's training env steps, one line
    per training variant, with 95 % CIs. Returns False (and draws nothing) unless at
    least two controllers have known env steps."""
    points: dict[str, list[tuple[float, tuple[float, float, float, int]]]] = defaultdict(list)
    for label, rows in results.items():
        prov = provenance.get(label) or {}
        if rows and prov.get("env_steps") is not None:
            points[prov.get("variant", label)].append(
                (prov["env_steps"] / 1e6, _rate(rows, "stuck_low")))
    if sum(len(v) for v in points.values()) < 2:
        return False
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for variant, pts in sorted(points.items()):
        pts.sort()
        x = np.array([p[0] for p in pts])
        rate = np.array([p[1][0] for p in pts])
        err = np.array([[r - lo, hi - r] for _, (r, lo, hi, _n) in pts]).T
        ax.errorbar(x, rate, yerr=err, marker="o", capsize=3, label=variant)
    ax.set_xlabel("training env steps [millions]")
    ax.set_ylabel("stuck-low rate (all trials)")
    ax.set_xlim(left=0.0)
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Stuck low at deployment settings, by training budget")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return True


def _plot_lines(rows, x_key, y_fn, ylabel, title, path, x_label):
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for (pose,), group in _group(rows, "pose").items():
        xs, ys = [], []
        for (x,), sub in _group(group, x_key).items():
            y = y_fn(sub)
            if y is not None:
                xs.append(x)
                ys.append(y)
        ax.plot(xs, ys, marker="o", label=pose)
    finish_panel(fig, ax, title, x_label, ylabel, path)


def _mean_time(rows):
    times = [r["recovery_time"] for r in rows if r["success"]]
    return float(np.mean(times)) if times else None


def sweep_figures(rows: list[dict], out: Path, prefix: str = "") -> list[tuple[str, str]]:
    """The paper's Fig. 4 panels (A–F) as PNGs; returns (caption, file name) pairs."""
    figs = []
    unpushed = [r for r in rows if r["force"] == 0]
    if unpushed:
        fig, ax = plt.subplots(figsize=(5.5, 3.2))
        groups = _group(unpushed, "pose")
        rates = [_rate(g) for g in groups.values()]
        ax.bar([p for (p,) in groups], [r[0] for r in rates],
               yerr=np.array([[r[0] - r[1] for r in rates], [r[2] - r[0] for r in rates]]),
               capsize=4)
        ax.set_ylim(0, 1.05)
        ax.set_ylabel("success rate")
        ax.set_title("(A) recovery without push")
        fig.tight_layout()
        name = f"{prefix}A_no_push.png"
        with atomic_path(out / name) as tmp:
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        figs.append(("(A) success without push, per pose (95 % CI)", name))
    panels = [
        ("force", lambda g: _rate(g)[0], "success rate", "(B–C) success vs force", "BC_force",
         "push force [N]"),
        ("force", _mean_time, "mean recovery time [s]", "(D) recovery time vs force",
         "D_time", "push force [N]"),
        ("height", lambda g: _rate(g)[0], "success rate", "(F) push height sensitivity",
         "F_height", "push height above CoM [m]"),
    ]
    pushed = [r for r in rows if r["force"] > 0] or rows
    for key, fn, ylabel, title, stem, xlabel in panels:
        source = rows if key == "force" else pushed
        name = f"{prefix}{stem}.png"
        _plot_lines(source, key, fn, ylabel, title, out / name, xlabel)
        figs.append((title, name))
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    poses = list(_group(pushed, "pose"))
    directions = sorted({round(r["direction"], 4) for r in pushed})
    width = 0.8 / max(len(directions), 1)
    for j, d in enumerate(directions):
        vals = [_rate([r for r in pushed if r["pose"] == p and round(r["direction"], 4) == d]
                      or [{"success": False}])[0] for (p,) in poses]
        ax.bar(np.arange(len(poses)) + j * width, vals, width,
               label=_DIRECTION_NAMES.get(d, f"{d:.2f}"))
    ax.set_xticks(np.arange(len(poses)) + 0.4 - width / 2, [p for (p,) in poses])
    ax.set_ylabel("success rate")
    ax.set_title("(E) push direction sensitivity")
    ax.legend(fontsize=8)
    fig.tight_layout()
    name = f"{prefix}E_direction.png"
    with atomic_path(out / name) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    figs.append(("(E) push direction sensitivity", name))
    return figs


def capture_point_figure(trace: dict, push_time: float, path: Path, title: str = "") -> None:
    """ξ over time with the active foot support polygons (the paper's Fig. 3)."""
    fig, ax = plt.subplots(figsize=(5, 5))
    t, cp, com = trace["t"], trace["cp"], trace["com"]
    feet = trace["feet_xy"]  # (T, 2, 4, 2), NaN where no contact
    for k in range(0, len(t), max(1, len(t) // 12)):
        for foot in range(2):
            pts = feet[k, foot][~np.isnan(feet[k, foot, :, 0])]
            if len(pts):
                poly = support_polygon(pts)
                closed = np.vstack([poly, poly[:1]])
                ax.plot(closed[:, 0], closed[:, 1], color="0.6", lw=0.8)
    sc = ax.scatter(cp[:, 0], cp[:, 1], c=t, cmap="viridis", s=10, label="capture point ξ")
    ax.plot(com[:, 0], com[:, 1], color="tab:red", lw=1, label="CoM projection")
    k0 = int(np.searchsorted(t, push_time))
    if k0 < len(t):
        ax.scatter(cp[k0, 0], cp[k0, 1], marker="x", color="k", s=60, label="push")
    fig.colorbar(sc, ax=ax, label="t [s]")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or "capture point and foot support polygons")
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def write_report(results: dict[str, list[dict]], out_dir: str | Path, title: str,
                 cp_traces: dict[str, tuple[dict, float]] | None = None,
                 ablation: str | None = None, notes: str = "",
                 sweep_plots: bool = True, provenance: dict[str, dict] | None = None) -> Path:
    """Writes ``report.md`` and its PNGs for one or more controllers' results.

    Args:
        results: controller label → result rows.
        out_dir: output directory.
        title: report title.
        cp_traces: controller label → (recorded trace, push time) for the CP figure.
        ablation: a Markdown ablation table to include.
        notes: Markdown paragraphs placed after the title.
        sweep_plots: draw the force/direction/height panels when forces vary.
        provenance: controller label → its policy's training provenance (``variant``,
            ``iteration``, ``env_steps``), for the comparison table and the stuck-low
            figure drawn when there are several controllers.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md = [f"# {title}", "", notes, ""]
    if len(results) > 1:
        md += ["## Comparison", "", comparison_table(results, provenance), ""]
        if stuck_low_figure(results, provenance or {}, out / "stuck_low_vs_budget.png"):
            md += ["![stuck-low rate by training budget](stuck_low_vs_budget.png)", ""]
        first = next(iter(results))
        md += [f"Success-rate differences against {first} (Newcombe 95 % intervals):", "",
               difference_table(results), ""]
        if sweep_plots and all(results.values()):
            for caption, name in overlay_figures(results, out):
                md += [f"![{caption}]({name})", ""]
    for label, rows in results.items():
        safe = "".join(ch if ch.isalnum() else "_" for ch in label)[:40]
        md += [f"## {label}", "", summary_table(rows), ""]
        if diverged := _diverged(rows):
            md += [f"{diverged} of {len(rows)} trials diverged (the simulation became "
                   "unstable; each row's `divergence` says why and when): they count as "
                   "failures, never as recoveries.", ""]
        pushed = [r for r in rows if r["force"] > 0]
        if pushed and len({r["pose"] for r in rows}) == 1:
            md += ["Push hierarchy (success and most frequent strategy):", "",
                   strategy_table(pushed), ""]
        if sweep_plots and len({r["force"] for r in rows}) > 1:
            for caption, name in sweep_figures(rows, out, prefix=f"{safe}_"):
                md += [f"![{caption}]({name})", ""]
        if cp_traces and label in cp_traces:
            name = f"{safe}_capture_point.png"
            trace, push_time = cp_traces[label]
            capture_point_figure(trace, push_time, out / name, f"{label}: capture point")
            md += [f"![capture point evolution]({name})", ""]
    if ablation:
        md += ["## Ablation", "", ablation, ""]
    atomic_write_text("\n".join(md), out / "report.md")
    atomic_write_text(json.dumps(
        {k: [{kk: vv for kk, vv in r.items() if kk != "trace"} for r in v]
         for k, v in results.items()}, default=str), out / "results.json")
    return out / "report.md"
