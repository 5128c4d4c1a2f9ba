"""Deterministic, unassisted rises of runs' actors from each level of the recorded-rise starts.

For every level k = 0 … K − 1 of ``rises.levels`` = K (stretch k of each recorded move,
0 ending at the hand-over, K − 1 beginning at the ground pose) and k = K (the pose's own
settled start), all envs start there, with the run's training settings otherwise, the
assistance off and episodes of ``--seconds``; the share that stands up (CoM above
0.85 m, torso within 72°, for 1 s) says how far back along the move each actor rises.
Per level it also gives the share of episodes that start chest up (the torso's forward
axis within 53° of vertical, ``chest_up_at_start``) and the share that turn chest down
(beyond 53° below horizontal) at some time in the episode (``turned_chest_down``): the
roll from the back, which the moves make and the actor must learn.

    python research/probe_rise_levels.py runs/run_a --rises rises/sitting.npz --envs 32
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from hybrid_recovery.training.export import actor_from_checkpoint
from hybrid_recovery.training.probe import first_episodes, training_env


def probe(run: Path, rises: Path, levels: int, num_envs: int, seed: int,
          seconds: float, first: int = 0) -> dict:
    """Stand-up share of ``run``'s latest actor from each level ``first`` … K of
    ``rises``' starts."""
    env, data = training_env(run, num_envs, seed, {
        "rises.files": [str(rises)], "rises.levels": levels, "episode_length_s": seconds})
    (pose,) = env.rises.poses
    env.cfg.pose_weights = {pose: 1.0}  # every start from the recording's pose
    env.assist.fraction = 0.0
    actor = actor_from_checkpoint(data)
    shares: dict[str, dict[str, float]] = {"stood_up_by_level": {},
                                           "chest_up_at_start_by_level": {},
                                           "turned_chest_down_by_level": {}}
    for k in range(first, levels + 1):
        env.rises.level[pose] = k
        watch = ChestWatch(env)
        stood, _ = first_episodes(env, actor, watch)
        for key, values in (("stood_up_by_level", stood), ("chest_up_at_start_by_level",
                            watch.start > CHEST_AXIS), ("turned_chest_down_by_level",
                                                        watch.lowest < -CHEST_AXIS)):
            shares[key][f"{k}/{levels}"] = round(float(np.mean(values)), 3)
    return {"run": str(run), "iteration": int(data["iter"]), "pose": pose,
            "episodes": num_envs, "seconds": seconds, **shares}


CHEST_AXIS = 0.6
"""|z| of the torso's forward axis beyond which the chest faces up (or down)."""


class ChestWatch:
    """The z component of the torso's forward axis of each env's first episode: at its
    start (``start`` (N,)) and the lowest reached (``lowest`` (N,))."""

    def __init__(self, env) -> None:
        self.env = env
        self.start, self.lowest = np.zeros(0), np.zeros(0)  # set by the first call

    def __call__(self, live: np.ndarray) -> None:
        z = self.env.xmat[:, self.env.torso, 6]  # row 2, column 0 of the rotation
        if not len(self.start):
            self.start, self.lowest = z.copy(), z.copy()
        self.lowest[live] = np.minimum(self.lowest[live], z[live])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--rises", type=Path, nargs="+", required=True,
                        help="recordings of `hybrid-recovery getup record`")
    parser.add_argument("--levels", type=int, default=8)
    parser.add_argument("--envs", type=int, default=32, help="episodes per level and run")
    parser.add_argument("--seconds", type=float, default=8.0, help="episode length [s]")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--from-level", type=int, default=0,
                        help="probe levels from this one to K (the pose) only")
    args = parser.parse_args()
    torch.set_num_threads(1)
    for run in args.runs:
        for rises in args.rises:
            print(json.dumps(probe(run, rises, args.levels, args.envs, args.seed,
                                   args.seconds, args.from_level)), flush=True)


if __name__ == "__main__":
    main()
