"""Starts along recorded rises: a reverse curriculum over the hybrid's ground moves
(beyond the paper).

A recording (``hybrid-recovery getup record``) holds states (qpos, qvel) sampled at
50 Hz along successful hybrid rises from one start pose: the settle, the model-based
ground moves, then the policy from the hand-over on. The *move* of an episode is its
samples from the first one after the settle up to (not including) the first one of the
policy, or to its end when the policy never took over. Each sample of a move has the
progress u = (t − t₀) / (t_h − t₀) ∈ [0, 1), t₀ the move's first sample, t_h the
hand-over, and belongs to stretch k = K − 1 − ⌊u K⌋ of K, the one of u ∈ [(K − 1 − k)/K,
(K − k)/K): stretch 0 ends at the hand-over, stretch K − 1 begins at the ground pose.

A pose's starts are drawn from the stretch of its level k ∈ {0, …, K}; at K the pose's
own settled starts are used (the curriculum is done). The level moves on the stand-up
rate of the episodes started at it (:class:`~hybrid_recovery.envs.outcome_window.
OutcomeWindow`): one stretch toward the ground pose at ``advance``, one back below
``retreat`` (cf. reverse curricula from the goal, and the stage advance by success rate
of arXiv 2603.08619, Sec. III-F).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hybrid_recovery.envs.config import RiseConfig
from hybrid_recovery.envs.outcome_window import OutcomeWindow
from hybrid_recovery.sim.initial_states import POSES, quat_from_euler, quat_mul

SETTLE = "settle"
"""Phase of a recording's samples before the move begins."""
POLICY = "policy"
"""Phase of its samples once the policy has taken over (the hand-over)."""
_ARRAYS = ("qpos", "qvel", "time", "episode", "phase", "pose")
_HOW = ("write one with `hybrid-recovery getup record --pose POSE --episodes N --policy P "
        "--out FILE`")


@dataclass(frozen=True)
class RiseMoves:
    """The moves of one pose's recordings.

    Attributes:
        qpos: (M, nq) MuJoCo positions of every move sample.
        qvel: (M, nv) their velocities (free-joint linear velocity in the world frame).
        stretch: (M,) int, the stretch k ∈ {0, …, K − 1} of each sample.
        remaining: (M,) int, the samples after each one on its move (0 at a move's last).
    """

    qpos: np.ndarray
    qvel: np.ndarray
    stretch: np.ndarray
    remaining: np.ndarray


def move_progress(time: np.ndarray, episode: np.ndarray, phase: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Which samples are on a move and their progress u ∈ [0, 1) toward the hand-over.

    Args:
        time: (T,) [s] from each episode's start; episode: (T,) int; phase: (T,) str.

    Returns:
        (on_move (T,) bool, u (T,) with NaN off the moves).
    """
    on_move, u = np.zeros(len(time), dtype=bool), np.full(len(time), np.nan)
    for ep in np.unique(episode):
        rows = np.flatnonzero(episode == ep)
        phases = phase[rows]
        moving = np.flatnonzero(phases != SETTLE)
        if not len(moving):
            continue
        first = moving[0]
        handed = np.flatnonzero(phases == POLICY)
        end = handed[0] if len(handed) else len(rows)
        if end <= first:
            continue
        move = rows[first:end]
        t0 = time[move[0]]
        if end < len(rows):  # the hand-over's time
            t_h = time[rows[end]]
        else:  # none: one sample period after the move's last sample
            t_h = time[move[-1]] + (time[move[-1]] - time[move[-2]] if len(move) > 1 else 1.0)
        on_move[move] = True
        u[move] = (time[move] - t0) / (t_h - t0)
    return on_move, u


def stretch_of(u: np.ndarray, levels: int) -> np.ndarray:
    """Stretch k = K − 1 − ⌊u K⌋ of progress u ∈ [0, 1), shape as ``u``, int (u K within
    1e-9 of a whole number counts as it: times sampled at 50 Hz are not exact in binary)."""
    return levels - 1 - np.clip(np.floor(u * levels + 1e-9).astype(int), 0, levels - 1)


def load_rises(path: str | Path, levels: int, nq: int, nv: int) -> tuple[str, RiseMoves]:
    """The start pose and the moves of one recording.

    Raises:
        ValueError: no such file, not a recording, arrays of the wrong type (qpos, qvel,
            time real numbers, episode integers, phase strings, pose one string) or
            shape, NaN, a base quaternion qpos[3:7] whose norm is not 1 ± 0.01 (the
            message names the episode and the time), an unknown pose, no move, or a
            stretch without a sample; the message names the file and the problem.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"rises.files: no such file: {path} ({_HOW})")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in _ARRAYS if key in data.files}
    except (OSError, ValueError) as err:
        raise ValueError(f"rise recording {path} is not an .npz file: {err}") from None
    missing = [key for key in _ARRAYS if key not in arrays]
    if missing:
        raise ValueError(f"rise recording {path} has no {missing} ({_HOW})")
    _check_dtypes(path, arrays)
    qpos, qvel = arrays["qpos"], arrays["qvel"]
    if qpos.ndim != 2 or qpos.shape[1] != nq:
        raise ValueError(f"rise recording {path}: qpos has shape {qpos.shape}, expected "
                         f"(T, {nq})")
    count = len(qpos)
    if qvel.shape != (count, nv):
        raise ValueError(f"rise recording {path}: qvel has shape {qvel.shape}, expected "
                         f"({count}, {nv})")
    for key in ("time", "episode", "phase"):
        if arrays[key].shape != (count,):
            raise ValueError(f"rise recording {path}: {key} has shape {arrays[key].shape}, "
                             f"expected ({count},)")
    if not (np.isfinite(qpos).all() and np.isfinite(qvel).all()
            and np.isfinite(arrays["time"]).all()):
        raise ValueError(f"rise recording {path}: qpos, qvel or time holds NaN or inf")
    _check_quaternions(path, qpos, arrays["episode"], arrays["time"])
    pose = str(arrays["pose"])
    if pose not in POSES:
        raise ValueError(f"rise recording {path}: unknown pose '{pose}'; known: "
                         f"{list(POSES)}")
    on_move, u = move_progress(arrays["time"], arrays["episode"], arrays["phase"].astype(str))
    if not on_move.any():
        raise ValueError(f"rise recording {path}: no move (no sample after the settle "
                         f"and before the hand-over to the policy)")
    stretch = stretch_of(u[on_move], levels)
    remaining = _remaining(arrays["episode"][on_move])
    empty = sorted(set(range(levels)) - set(stretch.tolist()))
    if empty:
        raise ValueError(f"rise recording {path}: rises.levels = {levels} leaves stretches "
                         f"{empty} without a sample; use fewer levels")
    return pose, RiseMoves(qpos[on_move].copy(), qvel[on_move].copy(), stretch, remaining)


def _remaining(episode: np.ndarray) -> np.ndarray:
    """Samples after each one of its run of equal ``episode`` (M,) ids, (M,) int: each
    episode's move samples are one contiguous run (:func:`move_progress`)."""
    starts = np.flatnonzero(np.r_[True, episode[1:] != episode[:-1]])
    ends = np.r_[starts[1:], len(episode)] - 1
    last = np.repeat(ends, np.diff(np.r_[starts, len(episode)]))
    return last - np.arange(len(episode))


QUATERNION_TOLERANCE = 0.01
"""A recorded base quaternion's norm may differ from 1 by this much (MuJoCo's integrator
keeps it within ~1e-9)."""
_KINDS = {"qpos": ("fi", "real numbers"), "qvel": ("fi", "real numbers"),
          "time": ("fi", "real numbers"), "episode": ("iu", "integers"),
          "phase": ("US", "strings"), "pose": ("US", "a string")}
"""Array → (numpy dtype kinds allowed, what the message calls them)."""


def _check_dtypes(path: Path, arrays: dict[str, np.ndarray]) -> None:
    for key, (kinds, what) in _KINDS.items():
        if arrays[key].dtype.kind not in kinds:
            raise ValueError(f"rise recording {path}: {key} must hold {what}, got dtype "
                             f"{arrays[key].dtype}")
    if arrays["pose"].ndim != 0:
        raise ValueError(f"rise recording {path}: pose must be one string, got shape "
                         f"{arrays['pose'].shape}")


def _check_quaternions(path: Path, qpos: np.ndarray, episode: np.ndarray,
                       time: np.ndarray) -> None:
    """Every base quaternion qpos[3:7] of unit norm; the first that is not is named."""
    norm = np.linalg.norm(qpos[:, 3:7], axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > QUATERNION_TOLERANCE)
    if len(bad):
        row = int(bad[0])
        raise ValueError(f"rise recording {path}: episode {int(episode[row])} has a base "
                         f"quaternion qpos[3:7] of norm {norm[row]:.3g} at {time[row]:.2f} s "
                         f"(sample {row}; {len(bad)} samples off 1 ± {QUATERNION_TOLERANCE})")


def turned(qpos: np.ndarray, qvel: np.ndarray, yaw: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """States turned about the world's vertical axis through the origin by ``yaw`` (n,)
    [rad]: base position, orientation and world-frame linear velocity rotate; the
    body-frame angular velocity and the joints do not. A symmetry of the flat floor.

    Args:
        qpos: (n, nq); qvel: (n, nv).
    """
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (n, 2, 2)
    qpos, qvel = qpos.copy(), qvel.copy()
    qpos[:, :2] = np.einsum("nij,nj->ni", rot, qpos[:, :2])
    zero = np.zeros_like(yaw)
    qpos[:, 3:7] = quat_mul(quat_from_euler(zero, zero, yaw), qpos[:, 3:7])
    qvel[:, :2] = np.einsum("nij,nj->ni", rot, qvel[:, :2])
    return qpos, qvel


class RiseStarts:
    """One level k ∈ {0, …, K} per recorded pose, moved by its stand-up rate.

    Args:
        cfg: the settings (``files`` empty: off).
        nq, nv: the model's position and velocity sizes (34, 33 for the H1-2).

    Raises:
        ValueError: bad settings or a bad recording (see :func:`load_rises`).
    """

    def __init__(self, cfg: RiseConfig, nq: int, nv: int) -> None:
        if cfg.levels < 1 or cfg.window < 1 or not 0.0 <= cfg.retreat < cfg.advance <= 1.0:
            raise ValueError(f"rises needs levels >= 1, window >= 1 and 0 <= retreat < "
                             f"advance <= 1; got {cfg.levels}, {cfg.window}, {cfg.retreat}, "
                             f"{cfg.advance}")
        self.cfg = cfg
        found: dict[str, list[RiseMoves]] = {}
        for path in cfg.files:
            pose, moves = load_rises(path, cfg.levels, nq, nv)
            found.setdefault(pose, []).append(moves)
        self.moves = {pose: RiseMoves(*(np.concatenate([getattr(m, f) for m in parts])
                                        for f in ("qpos", "qvel", "stretch", "remaining")))
                      for pose, parts in found.items()}
        """Moves of every recorded pose, all its files together."""
        self.level = dict.fromkeys(self.moves, 0)
        self._outcomes = {pose: OutcomeWindow(cfg.window) for pose in self.moves}

    @property
    def poses(self) -> tuple[str, ...]:
        """The poses with recordings."""
        return tuple(self.moves)

    def active(self, pose: str) -> bool:
        """Whether ``pose``'s episodes still start from its recorded moves."""
        return pose in self.level and self.level[pose] < self.cfg.levels

    def draw(self, pose: str, count: int, rng: np.random.Generator
             ) -> tuple[np.ndarray, np.ndarray]:
        """``count`` recorded states of ``pose``'s current stretch, uniformly.

        Returns:
            (qpos (count, nq), qvel (count, nv)), copies of recorded samples.
        """
        moves = self.moves[pose]
        rows = np.flatnonzero(moves.stretch == self.level[pose])
        pick = rows[rng.integers(len(rows), size=count)]
        return moves.qpos[pick].copy(), moves.qvel[pick].copy()

    def rate(self, pose: str) -> float:
        """Stand-up rate of the episodes from ``pose``'s current level counted so far
        (since its last change), ∈ [0, 1]; 0 when none."""
        return self._outcomes[pose].rate

    def record(self, pose: str, stood_up: np.ndarray, levels: np.ndarray) -> int:
        """Adds the outcomes of ``pose``'s episodes started at the current level (their
        start ``levels`` (n,) int, ``stood_up`` (n,) bool); returns the level's change:
        +1 (toward the ground pose), −1 (back toward the hand-over, never below 0) or 0."""
        if not self.active(pose):
            return 0
        mine = np.atleast_1d(stood_up)[np.atleast_1d(levels) == self.level[pose]]
        step = self._outcomes[pose].level_step(mine, self.level[pose],
                                               self.cfg.advance, self.cfg.retreat)
        self.level[pose] += step
        return step

    def state_dict(self) -> dict:
        return {"level": dict(self.level), "levels": self.cfg.levels,
                "outcomes": {pose: o.state() for pose, o in self._outcomes.items()}}

    def load_state_dict(self, state: dict) -> None:
        """Restores the levels and windows of the poses it names that have recordings;
        saved with another K', a level k' becomes ⌊k' K / K'⌋ and its window starts
        afresh."""
        saved = int(state.get("levels", self.cfg.levels))
        for pose, k in state["level"].items():
            if pose not in self.level:
                continue
            outcomes = state.get("outcomes", {}).get(pose, [])
            if saved != self.cfg.levels:
                k, outcomes = int(k) * self.cfg.levels // saved, []
            self.level[pose] = min(int(k), self.cfg.levels)
            self._outcomes[pose] = OutcomeWindow(self.cfg.window, outcomes)
