"""Lifting assistance that is annealed away by success (beyond the paper)."""

from __future__ import annotations

from collections import deque

import numpy as np

from hybrid_recovery.envs.config import AssistConfig

MODES = ("pull", "gravity")


class Assist:
    """Upward force f m g, on the torso (``pull``) or spread over the bodies as their
    weights (``gravity``), f annealed from ``cfg.fraction`` to 0.

    Args:
        cfg: the assistance settings.
        window: finished episodes per decision (the curriculum's window).
        advance_success: success rate over ``window`` that earns one decay step.
    """

    def __init__(self, cfg: AssistConfig, window: int, advance_success: float) -> None:
        if cfg.mode not in MODES:
            raise ValueError(f"assist.mode must be one of {MODES}, got '{cfg.mode}'")
        self.cfg, self.advance_success = cfg, advance_success
        self.fraction = cfg.fraction if cfg.fraction >= cfg.floor else 0.0
        self._outcomes: deque[bool] = deque(maxlen=window)

    @property
    def active(self) -> bool:
        return self.fraction > 0.0

    def acceleration(self, gravity_b: np.ndarray, g: float,
                     height: np.ndarray | None = None) -> np.ndarray:
        """Upward force per unit mass f g, shape (N,) [m/s²]: 0 where the torso tilts
        beyond ``cfg.max_tilt`` or, given the CoM heights h_c (N,) [m], above
        ``cfg.max_height``. Times the robot's mass it is the pull on the torso, times each
        body's mass the lift of the ``gravity`` mode.

        Args:
            gravity_b: torso projected gravity (N, 3).
        """
        on = -gravity_b[:, 2] > np.cos(self.cfg.max_tilt)
        if height is not None:
            on = on & (height < self.cfg.max_height)
        return self.fraction * g * on

    def force_z(self, mass: np.ndarray, gravity_b: np.ndarray, g: float,
                height: np.ndarray | None = None) -> np.ndarray:
        """The pull f m g per env, shape (N,) [N], for total robot masses m (N,) [kg]."""
        return mass * self.acceleration(gravity_b, g, height)

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
        self._outcomes.extend(bool(s) for s in np.atleast_1d(success))
        if len(self._outcomes) < (self._outcomes.maxlen or 1):
            return False
        if np.mean(self._outcomes) < self.advance_success:
            return False
        self._outcomes.clear()
        self.fraction *= self.cfg.decay
        if self.fraction < self.cfg.floor:
            self.fraction = 0.0
        return True

    def state_dict(self) -> dict:
        return {"fraction": self.fraction, "outcomes": list(self._outcomes)}

    def load_state_dict(self, state: dict) -> None:
        self.fraction = float(state["fraction"])
        self._outcomes = deque(state.get("outcomes", []), maxlen=self._outcomes.maxlen)
