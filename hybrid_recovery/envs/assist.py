"""Lifting assistance that is annealed away by success (beyond the paper)."""

from __future__ import annotations

import numpy as np

from hybrid_recovery.envs.config import AssistConfig
from hybrid_recovery.envs.outcome_window import OutcomeWindow


class Assist:
    """Upward pull f m g on the torso, f annealed from ``cfg.fraction`` to 0.

    Args:
        cfg: the assistance settings.
        window: finished episodes per decision (the curriculum's window).
        advance_success: success rate over ``window`` that earns one decay step.
    """

    def __init__(self, cfg: AssistConfig, window: int, advance_success: float) -> None:
        self.cfg, self.advance_success = cfg, advance_success
        self.fraction = cfg.fraction if cfg.fraction >= cfg.floor else 0.0
        self._outcomes = OutcomeWindow(window)

    @property
    def active(self) -> bool:
        return self.fraction > 0.0

    def force_z(self, mass: np.ndarray, gravity_b: np.ndarray, g: float,
                height: np.ndarray | None = None) -> np.ndarray:
        """The pull f m g per env, shape (N,) [N], for total robot masses m (N,) [kg]: 0
        where the torso tilts beyond ``cfg.max_tilt`` or, given the CoM heights h_c (N,)
        [m], above ``cfg.max_height``.

        Args:
            gravity_b: torso projected gravity (N, 3).
        """
        on = -gravity_b[:, 2] > np.cos(self.cfg.max_tilt)
        if height is not None:
            on = on & (height < self.cfg.max_height)
        return mass * self.fraction * g * on

    def assisted(self, start_poses: np.ndarray) -> np.ndarray:
        """Which episodes, by start pose name (N,), the force acts on, shape (N,) bool."""
        if not self.active:
            return np.zeros(len(start_poses), dtype=bool)
        if self.cfg.poses is None:
            return np.ones(len(start_poses), dtype=bool)
        return np.isin(start_poses, self.cfg.poses)

    def record(self, success: np.ndarray) -> bool:
        """Adds finished episodes' outcomes; decays the force when earned."""
        if not self.active:
            return False
        self._outcomes.extend(success)
        if self._outcomes.verdict(self.advance_success) < 1:
            return False
        self._outcomes.clear()
        self.fraction *= self.cfg.decay
        if self.fraction < self.cfg.floor:
            self.fraction = 0.0
        return True

    def state_dict(self) -> dict:
        return {"fraction": self.fraction, "outcomes": self._outcomes.state()}

    def load_state_dict(self, state: dict) -> None:
        self.fraction = float(state["fraction"])
        self._outcomes = OutcomeWindow(self._outcomes.size, state.get("outcomes", []))
