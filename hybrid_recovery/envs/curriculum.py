"""The three-stage curriculum of the paper (§III-F), as a small state machine with saved state."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hybrid_recovery.envs.config import CurriculumConfig
from hybrid_recovery.envs.outcome_window import OutcomeWindow


@dataclass
class Curriculum:
    """Stage 1 → 2 → 3 with a level in [0, 1] inside stages 2 and 3.

    Stage 1 ends at the first advance. In stage 2, ``level`` is the difficulty (pushes,
    domain randomisation, share of hard poses); in stage 3 it is the annealing progress
    (torque scale from ``torque_scale_explore`` to 1, position-limit factor from 1 to
    ``position_limit_final``). Each advance needs a success rate of at least
    ``advance_success`` over the last ``window`` finished episodes, which are then
    forgotten, so every step is earned at the new difficulty.
    """

    cfg: CurriculumConfig
    stage: int = 1
    level: float = 0.0
    _outcomes: OutcomeWindow = field(init=False)

    def __post_init__(self) -> None:
        self._outcomes = OutcomeWindow(self.cfg.window)
        if not self.cfg.enabled:
            self.stage, self.level = 3, 1.0

    @property
    def difficulty(self) -> float:
        """Pushes, DR and hard-pose share, 0 (none) … 1 (full)."""
        return {1: 0.0, 2: self.level, 3: 1.0}[self.stage]

    @property
    def torque_scale(self) -> float:
        """Multiplier of the hardware effort limits."""
        if self.stage < 3:
            return self.cfg.torque_scale_explore
        return self.cfg.torque_scale_explore + (1.0 - self.cfg.torque_scale_explore) * self.level

    @property
    def position_limit_factor(self) -> float:
        """Multiplier of the joint position ranges about their middle."""
        if self.stage < 3:
            return 1.0
        return 1.0 + (self.cfg.position_limit_final - 1.0) * self.level

    def record(self, success: np.ndarray) -> bool:
        """Adds finished episodes' outcomes; advances when earned. Returns True on advance."""
        self._outcomes.extend(success)
        if not self.cfg.enabled or self._outcomes.verdict(self.cfg.advance_success) < 1:
            return False
        if self.stage == 3 and self.level >= 1.0 - 1e-9:
            return False
        self._outcomes.clear()
        if self.stage == 1:
            self.stage, self.level = 2, self.cfg.step
        elif self.level + 1e-9 < 1.0:
            # rounded, so that ten steps of 0.1 reach exactly 1.0 (not 0.9999999999999999)
            self.level = min(1.0, round(self.level + self.cfg.step, 9))
        else:  # stage 2 at level 1
            self.stage, self.level = 3, self.cfg.step
        return True

    def state_dict(self) -> dict:
        return {"stage": self.stage, "level": self.level, "outcomes": self._outcomes.state()}

    def load_state_dict(self, state: dict) -> None:
        self.stage, self.level = int(state["stage"]), float(state["level"])
        self._outcomes = OutcomeWindow(self.cfg.window, state.get("outcomes", []))
