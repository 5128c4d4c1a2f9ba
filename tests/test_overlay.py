"""Overlaid comparison panels and the table of success-rate differences."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.evaluation.overlay import (
    difference_interval,
    difference_table,
    overlay_figures,
)
from hybrid_recovery.evaluation.scenario import SWEEP_DIRECTIONS


@pytest.mark.parametrize(("counts", "expected"), [
    ((56, 70, 48, 80), (0.0524, 0.3339)),
    ((9, 10, 3, 10), (0.1705, 0.8090)),
    ((6, 7, 2, 7), (0.0582, 0.8062)),
    ((5, 56, 0, 29), (-0.0381, 0.1926)),
    ((10, 10, 0, 10), (0.6075, 1.0)),
])
def test_difference_interval_matches_newcombes_published_values(counts, expected):
    """Newcombe (1998), Stat. Med. 17:873, Table II, method 10."""
    d, lo, hi = difference_interval(*counts)
    assert d == pytest.approx(counts[0] / counts[1] - counts[2] / counts[3])
    assert (lo, hi) == pytest.approx(expected, abs=1e-4)


def test_difference_interval_refuses_an_empty_sample():
    with pytest.raises(ValueError) as info:
        difference_interval(0, 0, 1, 2)
    assert str(info.value) == "difference_interval needs trials in both samples"


def _rows(wins: dict[tuple[float, str], tuple[int, int]]) -> list[dict]:
    rows = []
    for (force, direction), (k, n) in wins.items():
        rows += [{"pose": "standing", "force": force, "direction": SWEEP_DIRECTIONS[direction],
                  "height": 0.0, "success": i < k, "recovery_time": 1.0 if i < k else None}
                 for i in range(n)]
    return rows


def test_difference_table_rows():
    results = {"learned": _rows({(0.0, "front"): (4, 4), (300.0, "left"): (3, 4)}),
               "hybrid": _rows({(0.0, "front"): (4, 4), (300.0, "left"): (4, 4)})}
    lines = difference_table(results).splitlines()
    assert lines[0] == "| cell | learned k/n | hybrid k/n | hybrid − learned [95 % CI] |"
    d, lo, hi = difference_interval(4, 4, 3, 4)
    assert lines[3] == f"| 300 N left | 3/4 | 4/4 | {d:+.0%} [{lo:+.0%}, {hi:+.0%}] |"
    d, lo, hi = difference_interval(8, 8, 7, 8)
    assert lines[-1] == f"| all | 7/8 | 8/8 | {d:+.0%} [{lo:+.0%}, {hi:+.0%}] |"


def test_overlay_figures_one_per_panel(tmp_path):
    cells = {(f, d): (2, 3) for f in (0.0, 200.0, 400.0) for d in ("front", "left")}
    results = {"qp": _rows(cells), "learned": _rows({c: (3, 3) for c in cells})}
    figs = overlay_figures(results, tmp_path)
    names = [name for _, name in figs]
    assert names == ["overlay_A_no_push.png", "overlay_BC_force.png", "overlay_D_time.png",
                     "overlay_E_direction.png", "overlay_F_height.png"]
    sizes = np.array([(tmp_path / n).stat().st_size for n in names])
    assert np.all(sizes > 5_000) and np.all(sizes < 150_000)


def test_overlay_figures_without_pushes_draw_no_empty_panels(tmp_path):
    """The poses protocol has no pushes: panels of pushes (E, F) are not drawn empty."""
    results = {"model": _rows({(0.0, "front"): (1, 3)}), "hybrid": _rows({(0.0, "front"): (3, 3)})}
    names = [name for _, name in overlay_figures(results, tmp_path)]
    assert names == ["overlay_A_no_push.png", "overlay_BC_force.png", "overlay_D_time.png"]
    assert sorted(p.name for p in tmp_path.glob("*.png")) == sorted(names)
