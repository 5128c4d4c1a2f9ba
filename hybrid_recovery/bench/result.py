"""BenchResult: the figures of one benchmark run, as a table and as one JSON line."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class BenchResult:
    """One bench run: a human-readable table and machine-readable figures.

    Attributes:
        name: The bench target, e.g. ``"dynamics"``.
        title: One line saying what was measured and under which load.
        columns: Column headers of the table.
        rows: Table rows, one tuple of ``len(columns)`` cells each; floats are printed
            with 3 decimals.
        figures: JSON-serialisable figures (timings, ratios, settings).
    """

    name: str
    title: str
    columns: tuple[str, ...]
    rows: list[tuple[Any, ...]] = field(default_factory=list)
    figures: dict[str, Any] = field(default_factory=dict)

    def table(self) -> str:
        """The title, then the rows aligned under the column headers."""
        cells = [list(self.columns)] + [[_cell(v) for v in row] for row in self.rows]
        widths = [max(len(r[k]) for r in cells) for k in range(len(self.columns))]
        lines = [self.title]
        for i, row in enumerate(cells):
            first = row[0].ljust(widths[0])
            lines.append("  ".join([first] + [c.rjust(w) for c, w in zip(row[1:], widths[1:],
                                                                            strict=True)]))
            if i == 0:
                lines.append("  ".join("-" * w for w in widths))
        return "\n".join(lines)

    def json_line(self) -> str:
        """``{"bench": name, **figures}`` on one line."""
        return json.dumps({"bench": self.name, **self.figures}, sort_keys=False)


def _cell(value: Any) -> str:
    return f"{value:.3f}" if isinstance(value, float) else str(value)
