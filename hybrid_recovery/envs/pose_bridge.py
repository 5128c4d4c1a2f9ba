"""Start-pose bridges: a target pose's episodes start from blends of an easier source pose
and the target, moved toward the target as the stand-up rate allows (beyond the paper).

The blend at level k of K is the pose with joint targets q(t) = (1 − t) q_source + t
q_target and base pitch θ(t) likewise, t = k / K, settled from a drop like every pose of
:mod:`hybrid_recovery.sim.initial_states`; it is mirrored when either end is.
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.envs.config import BridgeConfig
from hybrid_recovery.envs.outcome_window import OutcomeWindow
from hybrid_recovery.sim.initial_states import POSE_LIBRARY, POSES, Pose


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
    """One level k ∈ {0, …, K} per target pose, moved by its stand-up rate: up one at
    ``advance`` or more over a full window, down one below ``retreat``.

    Args:
        cfg: the bridges' settings (``levels`` K = 0: off).
    """

    def __init__(self, cfg: BridgeConfig) -> None:
        pairs = [tuple(p) for p in cfg.pairs]
        for pair in pairs:
            if len(pair) != 2 or not set(pair) <= set(POSES) or pair[0] == pair[1]:
                raise ValueError(f"bridge.pairs needs (source, target) pairs of two "
                                 f"different poses of {list(POSES)}; got {list(pair)}")
        targets = [t for _, t in pairs]
        if len(set(targets)) < len(targets):
            raise ValueError(f"bridge.pairs has a target twice: {targets}")
        if cfg.levels < 0 or cfg.window < 1 or not 0.0 <= cfg.retreat < cfg.advance <= 1.0:
            raise ValueError(f"bridge needs levels >= 0, window >= 1 and 0 <= retreat < "
                             f"advance <= 1; got {cfg.levels}, {cfg.window}, {cfg.retreat}, "
                             f"{cfg.advance}")
        self.cfg = cfg
        self.source = {t: s for s, t in pairs}
        """Source pose by target pose."""
        self.level = dict.fromkeys(targets, 0)
        self._outcomes = {t: OutcomeWindow(cfg.window) for t in targets}

    @property
    def targets(self) -> tuple[str, ...]:
        return tuple(self.level) if self.cfg.levels else ()

    def active(self, target: str) -> bool:
        """Whether ``target``'s episodes still start from blends."""
        return target in self.targets and self.level[target] < self.cfg.levels

    def blend(self, target: str) -> float:
        """t of ``target``'s current starts: 0 (the source) … 1 (the target itself)."""
        return self.level[target] / self.cfg.levels if self.active(target) else 1.0

    def poses(self) -> dict[str, Pose]:
        """The blends of levels 0 … K − 1 of every bridge, by :meth:`pool_name`."""
        return {self.pool_name(t, k): blend_pose(POSE_LIBRARY[self.source[t]],
                                                 POSE_LIBRARY[t], k / self.cfg.levels)
                for t in self.targets for k in range(self.cfg.levels)}

    def pool_name(self, target: str, level: int | None = None) -> str:
        """Name of a level's blend (the current level's by default)."""
        k = self.level[target] if level is None else level
        return f"{target}@{k}/{self.cfg.levels}"

    def record(self, target: str, stood_up: np.ndarray, levels: np.ndarray | None = None) -> int:
        """Adds ``target`` episodes' known outcomes (a rise, or a failure at the end), of
        those that started at the current level when their start ``levels`` are given;
        returns the level's change (+1 when one is earned, −1 on a retreat, else 0)."""
        if not self.active(target):
            return 0
        stood_up = np.atleast_1d(stood_up)
        if levels is not None:
            stood_up = stood_up[np.atleast_1d(levels) == self.level[target]]
        step = self._outcomes[target].level_step(stood_up, self.level[target],
                                                 self.cfg.advance, self.cfg.retreat)
        self.level[target] += step
        return step

    def state_dict(self) -> dict:
        return {"level": dict(self.level), "levels": self.cfg.levels,
                "outcomes": {t: o.state() for t, o in self._outcomes.items()}}

    def load_state_dict(self, state: dict) -> None:
        """Restores the levels of the targets it names (of one bridge as
        ``{"level": k}``, the first), keeping the others at 0. Saved with another number
        of levels K', a level k' becomes the nearest level at or below the same blend
        k'/K' (the window starts afresh)."""
        levels, outcomes = state["level"], state.get("outcomes", {})
        if not isinstance(levels, dict):
            first = next(iter(self.level))
            levels, outcomes = {first: levels}, {first: outcomes or []}
        saved = int(state.get("levels", self.cfg.levels))
        for target, k in levels.items():
            if target not in self.level:
                continue
            if saved != self.cfg.levels and saved > 0:
                k, outcomes = int(k) * self.cfg.levels // saved, {}
            self.level[target] = min(int(k), self.cfg.levels)
            self._outcomes[target] = OutcomeWindow(self.cfg.window, outcomes.get(target, []))
