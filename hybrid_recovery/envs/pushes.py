"""Torso pushes (paper §III-G): horizontal forces of 50–300 N for 0.1–0.2 s at random times.

Once a robot has been upright for ``upright_time``, a push is with probability
``fall_probability`` a large fall-inducing one, so that episodes cover the whole
fall-and-recovery cycle. The curriculum's difficulty is the probability that a scheduled
push happens at all.
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.envs.config import PushConfig


class Pushes:
    """Per-env push schedule; :meth:`force` advances it by one control step.

    Args:
        cfg: push ranges.
        num_envs: N.
        dt: control period [s].
    """

    def __init__(self, cfg: PushConfig, num_envs: int, dt: float) -> None:
        self.cfg, self.dt = cfg, dt
        self.time_to_push = np.zeros(num_envs)
        self.remaining = np.zeros(num_envs)
        self.current = np.zeros((num_envs, 3))

    def reset(self, ids: np.ndarray, rng: np.random.Generator) -> None:
        self.time_to_push[ids] = rng.uniform(*self.cfg.interval, len(ids))
        self.remaining[ids] = 0.0
        self.current[ids] = 0.0

    def force(self, upright_time: np.ndarray, rng: np.random.Generator,
              difficulty: float) -> np.ndarray:
        """World force on the torso for this control step, shape (N, 3) [N]."""
        c = self.cfg
        self.remaining -= self.dt
        self.current[self.remaining <= 0.0] = 0.0
        self.time_to_push -= self.dt
        start = np.flatnonzero(self.time_to_push <= 0.0)
        if len(start):
            n = len(start)
            happen = rng.random(n) < difficulty
            fall = (upright_time[start] >= c.upright_time) & (rng.random(n) < c.fall_probability)
            magnitude = np.where(fall, rng.uniform(*c.fall_force, n), rng.uniform(*c.force, n))
            heading = rng.uniform(-np.pi, np.pi, n)
            self.current[start, 0] = happen * magnitude * np.cos(heading)
            self.current[start, 1] = happen * magnitude * np.sin(heading)
            self.current[start, 2] = 0.0
            self.remaining[start] = rng.uniform(*c.duration, n)
            self.time_to_push[start] = rng.uniform(*c.interval, n)
        return self.current
