"""Start-state replay: episodes that begin part-way along earlier stand-ups (beyond the paper).

While an episode from one of ``ReplayConfig.poses`` runs, its state is sampled every
``interval_s``. When it stands up (CoM above the success height, torso within 72°, for
1 s), the samples taken before it was up enter a buffer of start states. A fraction of
later episodes starts from a uniformly drawn buffered state instead of a settled pose,
and without assistance: the policy practises, unaided, every phase of rises that it
could so far only finish with help (the reverse curriculum / backplay idea of starting
closer to the goal along successful trajectories).
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.envs.config import ReplayConfig


class StartReplay:
    """Per-env trajectory samples and a ring buffer of stand-up states.

    Args:
        cfg: the replay settings.
        num_envs: N; nq, nv: the model's position and velocity sizes.
        episode_steps: control steps per episode (the most samples one episode can hold).
        dt: control period [s].
    """

    def __init__(self, cfg: ReplayConfig, num_envs: int, nq: int, nv: int,
                 episode_steps: int, dt: float) -> None:
        if not 0.0 <= cfg.fraction <= 1.0:
            raise ValueError(f"replay.fraction must be in [0, 1], got {cfg.fraction}")
        if cfg.capacity < 1 or cfg.interval_s <= 0.0:
            raise ValueError(f"replay.capacity must be >= 1 and replay.interval_s > 0, got "
                             f"{cfg.capacity} and {cfg.interval_s}")
        self.cfg = cfg
        self.every = max(1, int(round(cfg.interval_s / dt)))
        slots = episode_steps // self.every + 1
        self._traj_qpos = np.zeros((num_envs, slots, nq))
        self._traj_qvel = np.zeros((num_envs, slots, nv))
        self._traj_height = np.zeros((num_envs, slots))
        self._count = np.zeros(num_envs, dtype=int)
        self.qpos = np.zeros((cfg.capacity, nq))
        self.qvel = np.zeros((cfg.capacity, nv))
        self.pose = np.zeros(cfg.capacity, dtype=int)
        """Start pose (index into ``POSES``) of the episode each state came from."""
        self.size = 0
        self._head = 0

    @property
    def active(self) -> bool:
        return self.cfg.fraction > 0.0

    def clear(self, ids: np.ndarray) -> None:
        """Forgets the samples of envs ``ids`` (their episodes ended)."""
        self._count[ids] = 0

    def record(self, step: np.ndarray, qpos: np.ndarray, qvel: np.ndarray,
               height: np.ndarray, recording: np.ndarray) -> None:
        """Samples the envs that are ``recording`` (N,) bool at steps that are multiples of
        the interval; step: control steps into each episode (N,), taken before the step."""
        slots = self._traj_height.shape[1]
        due = np.flatnonzero(recording & (step % self.every == 0) & (self._count < slots))
        if len(due):
            k = self._count[due]
            self._traj_qpos[due, k], self._traj_qvel[due, k] = qpos[due], qvel[due]
            self._traj_height[due, k] = height[due]
            self._count[due] += 1

    def harvest(self, ids: np.ndarray, poses: np.ndarray, upright_height: float) -> int:
        """Buffers the samples of envs ``ids`` that have just stood up, those taken while
        the CoM was below ``upright_height`` [m]; poses: their start poses (len(ids),).
        Returns the number of states added."""
        added = 0
        for env, pose in zip(ids, poses, strict=True):
            n = self._count[env]
            low = np.flatnonzero(self._traj_height[env, :n] < upright_height)
            for k in low:
                self.qpos[self._head], self.qvel[self._head] = (self._traj_qpos[env, k],
                                                                self._traj_qvel[env, k])
                self.pose[self._head] = pose
                self._head = (self._head + 1) % len(self.pose)
            self.size = min(self.size + len(low), len(self.pose))
            added += len(low)
        self._count[ids] = 0  # each rise is harvested once
        return added

    def draw(self, count: int, rng: np.random.Generator) -> np.ndarray:
        """Which of ``count`` resets start from a buffered state, shape (count,) bool."""
        if not self.active or self.size == 0:
            return np.zeros(count, dtype=bool)
        return rng.random(count) < self.cfg.fraction

    def sample(self, count: int, rng: np.random.Generator
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``count`` buffered states drawn uniformly: qpos (count, nq), qvel (count, nv),
        start pose (count,)."""
        rows = rng.integers(self.size, size=count)
        return self.qpos[rows].copy(), self.qvel[rows].copy(), self.pose[rows].copy()
