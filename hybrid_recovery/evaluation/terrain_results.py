"""Trials on terrain: the controllers that decline it, and the terrain protocol's table
and figure (success against difficulty, one line per controller, a panel per kind)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybrid_recovery.evaluation.scenario import Scenario  # noqa: E402
from hybrid_recovery.evaluation.success import wilson_interval  # noqa: E402
from hybrid_recovery.files import atomic_path  # noqa: E402
from hybrid_recovery.sim.terrain import Terrain, parse_terrain  # noqa: E402

FLAT_GROUND_CONTROLLERS = ("qp", "model")
"""Controllers whose QP models the ground as the plane z = 0: they decline other ground
(the ``hybrid`` runs there: its supervisor keeps the QP out where the ground is tilted,
:mod:`hybrid_recovery.control.model_validity`)."""


def declined_reason(controller: str, terrain: Terrain) -> str | None:
    """Why ``controller`` (its name) does not run on ``terrain``; None where it does."""
    if terrain.is_flat or controller.partition(":")[0] not in FLAT_GROUND_CONTROLLERS:
        return None
    return (f"{controller} declines {terrain.text}: its QP models the ground as the plane "
            "z = 0 (contact normal +z, friction cone about it)")


def declined_row(scenario: Scenario, controller: str, model: str | None, contact: str,
                 rotor_inertia: bool, reason: str) -> dict:
    """The result row of a trial the controller declined: not run, not a success."""
    return {**scenario.to_dict(), "key": scenario.key, "controller": controller,
            "model": model or "own", "contact": contact, "rotor_inertia": rotor_inertia,
            "success": False, "recovery_time": None, "standing_at_end": False,
            "fell": False, "stuck_low": False, "peak_torque": 0.0, "time_low": 0.0,
            "strategy": "declined", "not_applicable": True, "declined": reason,
            "diverged": False, "divergence": None, "controller_info": {}}


def _by_terrain(rows: list[dict]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        out[row.get("terrain", "flat")].append(row)
    return out


def _cell(rows: list[dict]) -> str:
    if rows and all(r.get("declined") for r in rows):
        return "declined"
    k = sum(bool(r["success"]) for r in rows)
    lo, hi = wilson_interval(k, len(rows))
    return f"{k / len(rows):.0%} [{lo:.0%}, {hi:.0%}] (n={len(rows)})"


def terrain_table(results: dict[str, list[dict]]) -> str:
    """Markdown table: one row per terrain (flat first, then each kind by difficulty), one
    column per controller: success with its 95 % CI, or ``declined``."""
    grouped = {label: _by_terrain(rows) for label, rows in results.items()}
    terrains = sorted({t for g in grouped.values() for t in g}, key=_order)
    lines = ["| terrain | " + " | ".join(results) + " |", "|---" * (len(results) + 1) + "|"]
    for terrain in terrains:
        cells = [_cell(g[terrain]) if terrain in g else "–" for g in grouped.values()]
        lines.append(f"| {terrain} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def terrain_figure(results: dict[str, list[dict]], path: Path) -> bool:
    """Success against difficulty, a panel per terrain kind (flat ground at 0 in each),
    one line per controller with 95 % CIs; False (nothing drawn) without terrain rows."""
    present = {parse_terrain(r.get("terrain", "flat")).kind for rows in results.values()
               for r in rows}
    kinds = [kind for kind in ("slope", "rough", "step") if kind in present]
    if not kinds:
        return False
    units = {"slope": "slope [deg]", "rough": "largest height [cm]", "step": "height [cm]"}
    fig, axes = plt.subplots(1, len(kinds), figsize=(4.2 * len(kinds), 3.4), squeeze=False)
    for ax, kind in zip(axes[0], kinds, strict=True):
        for label, rows in results.items():
            points = []
            for text, group in _by_terrain(rows).items():
                terrain = parse_terrain(text)
                if terrain.kind not in (kind, "flat") or all(r.get("declined") for r in group):
                    continue
                k = sum(bool(r["success"]) for r in group)
                lo, hi = wilson_interval(k, len(group))
                points.append((terrain.difficulty, k / len(group), lo, hi))
            if points:
                x, y, lo, hi = np.array(sorted(points)).T
                ax.errorbar(x, y, yerr=np.stack([y - lo, hi - y]), marker="o", capsize=3,
                            label=label)
        ax.set(title=kind, xlabel=units[kind], ylabel="success", ylim=(-0.05, 1.05))
        ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return True


def terrain_section(results: dict[str, list[dict]], out: Path) -> str:
    """The report's terrain section (Markdown): the table and, on terrain, the figure
    ``terrain.png`` in ``out``; empty where every trial ran on flat ground."""
    if all(r.get("terrain", "flat") == "flat" for rows in results.values() for r in rows):
        return ""
    md = ["## Terrain", "", "Success from the start poses by terrain (95 % CI; "
          "`declined`: the controller does not run there, each row says why).", "",
          terrain_table(results), ""]
    if terrain_figure(results, out / "terrain.png"):
        md += ["![success against terrain difficulty](terrain.png)", ""]
    return "\n".join(md)


def _order(text: str) -> tuple[int, float]:
    terrain = parse_terrain(text)
    kinds = ("flat", "slope", "rough", "step")
    return (0 if terrain.is_flat else kinds.index(terrain.kind), terrain.difficulty)
