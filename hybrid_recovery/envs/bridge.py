"""Start-pose bridge: a target pose's episodes start from blends of an easier source pose
and the target, moved toward the target as the stand-up rate allows (beyond the paper).

The blend at level k of K is the pose with joint targets q(t) = (1 − t) q_source + t
q_target and base pitch θ(t) likewise, t = k / K, settled from a drop like every pose of
:mod:`hybrid_recovery.envs.initial_states`; it is mirrored when either end is.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from hybrid_recovery.envs.config import BridgeConfig
from hybrid_recovery.envs.initial_states import POSE_LIBRARY, POSES, Pose


def blend_pose(source: Pose, target: Pose, t: float) -> Pose:
    """The pose a fraction ``t`` ∈ [0, 1] of the way from ``source`` to ``target``.

    It settles for the shorter of the two settle times (a half-kneel tips over if held
    longer than its own).
    """
    if not 0.0 <= t <= 1.0:
        raise ValueError(f"blend fraction must be in [0, 1], got {t}")
    return Pose(joints=(1.0 - t) * source.joints + t * target.joints,
                pitch=(1.0 - t) * source.pitch + t * target.pitch,
                settle_time=min(source.settle_time, target.settle_time),
                mirrored=source.mirrored or target.mirrored)


class PoseBridge:
    """The bridge's level k ∈ {0, …, K}, advanced by the target's stand-up rate.

    Args:
        cfg: the bridge settings (``levels`` K = 0: off).
    """

    def __init__(self, cfg: BridgeConfig) -> None:
        for key in ("source", "target"):
            if getattr(cfg, key) not in POSES:
                raise ValueError(f"bridge.{key} '{getattr(cfg, key)}' is not a pose; "
                                 f"known: {list(POSES)}")
        if cfg.source == cfg.target:
            raise ValueError(f"bridge.source and bridge.target are both '{cfg.source}'")
        if cfg.levels < 0 or cfg.window < 1 or not 0.0 < cfg.advance <= 1.0:
            raise ValueError(f"bridge needs levels >= 0, window >= 1 and advance in (0, 1]; "
                             f"got {cfg.levels}, {cfg.window}, {cfg.advance}")
        self.cfg = cfg
        self.level = 0
        self.target_index = POSES.index(cfg.target)
        self._outcomes: deque[bool] = deque(maxlen=cfg.window)

    @property
    def active(self) -> bool:
        """Whether the target's episodes still start from blends."""
        return self.level < self.cfg.levels

    @property
    def blend(self) -> float:
        """t of the current starts: 0 (source) … 1 (the target itself)."""
        return self.level / self.cfg.levels if self.cfg.levels else 1.0

    def poses(self) -> dict[str, Pose]:
        """The blends of levels 0 … K − 1, by :meth:`pool_name`."""
        src, dst = POSE_LIBRARY[self.cfg.source], POSE_LIBRARY[self.cfg.target]
        return {self.pool_name(k): blend_pose(src, dst, k / self.cfg.levels)
                for k in range(self.cfg.levels)}

    def pool_name(self, level: int | None = None) -> str:
        """Name of a level's blend (the current level's by default)."""
        k = self.level if level is None else level
        return f"{self.cfg.target}@{k}/{self.cfg.levels}"

    def record(self, stood_up: np.ndarray) -> bool:
        """Adds finished target episodes' outcomes; returns True when a level is earned."""
        if not self.active:
            return False
        self._outcomes.extend(bool(s) for s in np.atleast_1d(stood_up))
        if len(self._outcomes) < self.cfg.window or np.mean(self._outcomes) < self.cfg.advance:
            return False
        self._outcomes.clear()
        self.level += 1
        return True

    def state_dict(self) -> dict:
        return {"level": self.level, "outcomes": list(self._outcomes)}

    def load_state_dict(self, state: dict) -> None:
        self.level = min(int(state["level"]), self.cfg.levels)
        self._outcomes = deque(state.get("outcomes", []), maxlen=self.cfg.window)
