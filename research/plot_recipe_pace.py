"""The recipe's pace: deployment stand-up rate per pose against env steps from the first
iteration, the from-scratch runs and the warm-started lineage on one plot.

Reads a table (CSV: ``arm, iteration, m_env_steps, pose, rate, trials``), one row per
evaluated checkpoint and pose: ``rate`` from ``hybrid-recovery eval --controller
onnx:EXPORT --protocol poses --trials 100 --seed 2 --stop-on-success`` of the checkpoint
exported (``hybrid-recovery export RUN --checkpoint RUN/model_N.pt``), ``trials`` that
pose's trials (blank where only the rate was reported: drawn without an interval). Dotted
lines at the milestones' rates, a dashed one at the 150 M env steps the recipe aims at.
Prints per arm the first checkpoint at each milestone: 1, sitting and supine ≥ 50 %; 2,
all five ≥ 80 %; 3, all five ≥ 93.4 % (the paper's rate; its mean time ≤ 5 s is not in
the table).

    python research/plot_recipe_pace.py docs/recipe_pace.csv --out docs/recipe_pace.png
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

from hybrid_recovery.evaluation.success import wilson_interval

POSES = ("kneeling", "sitting", "squatting", "standing", "supine")
MILESTONES = ((("sitting", "supine"), 0.5), (POSES, 0.8), (POSES, 0.934))
"""(poses, stand-up rate each must reach) of milestones 1–3; 93.4 % is the paper's (§IV-A)."""
TARGET_M_STEPS = 150.0
"""Env steps [M] by which the recipe aims at milestone 3."""


def read_table(path: Path) -> dict[str, list[dict]]:
    """arm → its rows (iteration, m_env_steps, pose, rate, trials or None), by env steps.

    Raises:
        ValueError: a row's rate outside [0, 1], or a column missing.
    """
    arms: dict[str, list[dict]] = {}
    with open(path, newline="") as f:
        for line, row in enumerate(csv.DictReader(f), start=2):
            try:
                rate = float(row["rate"])
                entry = {"iteration": int(row["iteration"]),
                         "m_env_steps": float(row["m_env_steps"]), "pose": row["pose"],
                         "rate": rate, "trials": int(row["trials"]) if row["trials"] else None}
            except (KeyError, TypeError, ValueError) as error:
                raise ValueError(f"{path}:{line}: {error}") from None
            if not 0.0 <= rate <= 1.0:
                raise ValueError(f"{path}:{line}: rate {rate} outside [0, 1]")
            arms.setdefault(row["arm"], []).append(entry)
    for rows in arms.values():
        rows.sort(key=lambda r: r["m_env_steps"])
    return arms


def first_at(rows: list[dict], poses: tuple[str, ...], level: float) -> float | None:
    """Env steps [M] of the first checkpoint at which each of ``poses`` was evaluated and
    stood up at ``level`` or above, None if none did."""
    by_iteration: dict[int, list[dict]] = {}
    for r in rows:
        by_iteration.setdefault(r["iteration"], []).append(r)
    for cells in sorted(by_iteration.values(), key=lambda c: c[0]["m_env_steps"]):
        rates = {c["pose"]: c["rate"] for c in cells}
        if all(rates.get(pose, -1.0) >= level for pose in poses):
            return cells[0]["m_env_steps"]
    return None


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("table", type=Path)
    p.add_argument("--out", type=Path, required=True, help="the PNG")
    args = p.parse_args()
    arms = read_table(args.table)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(POSES), figsize=(4.2 * len(POSES), 3.6), squeeze=False)
    for j, pose in enumerate(POSES):
        ax = axes[0, j]
        for k, (label, rows) in enumerate(arms.items()):
            mine = [r for r in rows if r["pose"] == pose]
            x, rate = [r["m_env_steps"] for r in mine], [r["rate"] for r in mine]
            lo, hi = [], []
            for r in mine:
                if r["trials"] is None:
                    lo.append(0.0)
                    hi.append(0.0)
                    continue
                low, high = wilson_interval(round(r["rate"] * r["trials"]), r["trials"])
                lo.append(r["rate"] - low)
                hi.append(high - r["rate"])
            ax.errorbar(x, rate, yerr=[lo, hi], color=f"C{k}", marker="o", ms=3, lw=1.1,
                        capsize=2, label=label)
        for level in sorted({level for _, level in MILESTONES}):
            ax.axhline(level, color="grey", ls=":", lw=0.8)
        ax.axvline(TARGET_M_STEPS, color="grey", ls="--", lw=0.8)
        ax.set_title(pose)
        ax.set_xlabel("M env steps from the first iteration")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("stand-up rate at deployment")
    axes[0, 0].legend(fontsize=7, loc="center left")
    fig.tight_layout()
    fig.savefig(args.out, dpi=70)
    for label, rows in arms.items():
        cells = []
        for k, (poses, level) in enumerate(MILESTONES, start=1):
            m = first_at(rows, poses, level)
            cells.append(f"milestone {k}: " + ("not reached" if m is None else f"{m} M"))
        print(f"{label} (evaluated to {rows[-1]['m_env_steps']} M): " + ", ".join(cells))


if __name__ == "__main__":
    main()
