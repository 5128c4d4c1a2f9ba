"""The success-rate window shared by the curricula: the curriculum, the assistance, the bridges.

Each decides on the outcomes (stood up or not) of its last ``size`` finished episodes:
once the window is full, a rate of at least ``advance`` earns a step forward, a rate
below ``retreat`` a step back; the caller acts and clears the window, so that every step
is earned afresh at the new setting (arXiv 2603.08619, Sec. III-D: stages advanced by
the success rate).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable, Iterator

import numpy as np


class OutcomeWindow:
    """The last ``size`` episode outcomes (bool), oldest dropped first.

    Args:
        size: episodes per decision, ≥ 1.

    Raises:
        ValueError: ``size`` < 1.
    """

    def __init__(self, size: int, outcomes: Iterable[bool] = ()) -> None:
        if size < 1:
            raise ValueError(f"an outcome window needs size >= 1, got {size}")
        self.size = size
        self._outcomes: deque[bool] = deque((bool(o) for o in outcomes), maxlen=size)

    def __len__(self) -> int:
        return len(self._outcomes)

    def __iter__(self) -> Iterator[bool]:
        return iter(self._outcomes)

    def extend(self, outcomes: np.ndarray | Iterable[bool]) -> None:
        """Adds finished episodes' outcomes, shape (n,) bool."""
        self._outcomes.extend(bool(o) for o in np.atleast_1d(np.asarray(outcomes)))

    @property
    def full(self) -> bool:
        return len(self._outcomes) == self.size

    @property
    def rate(self) -> float:
        """Success rate of the outcomes held, ∈ [0, 1] (0 when empty)."""
        return float(np.mean(self._outcomes)) if self._outcomes else 0.0

    def verdict(self, advance: float, retreat: float = -np.inf) -> int:
        """+1 when the window is full and its rate ≥ ``advance``, −1 when full and below
        ``retreat``, else 0. The window is kept: the caller clears it when it acts."""
        if not self.full:
            return 0
        rate = self.rate
        return 1 if rate >= advance else -1 if rate < retreat else 0

    def level_step(self, outcomes: np.ndarray | Iterable[bool], level: int,
                   advance: float, retreat: float) -> int:
        """Adds ``outcomes`` (n,) bool of episodes started at ``level`` and returns the
        level's change: +1, −1 (never below level 0) or 0; the window is cleared on a
        change, so the next step is earned at the new level."""
        self.extend(outcomes)
        step = self.verdict(advance, retreat)
        if step < 0 and level == 0:
            step = 0
        if step:
            self.clear()
        return step

    def clear(self) -> None:
        self._outcomes.clear()

    def state(self) -> list[bool]:
        """The outcomes held, oldest first (for checkpoints)."""
        return list(self._outcomes)
