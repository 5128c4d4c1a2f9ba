"""Deterministic, unassisted rises of runs' actors from each level of the recorded-rise starts.

For every level k = 0 … K − 1 of ``rises.levels`` = K (stretch k of each recorded move,
0 ending at the hand-over, K − 1 beginning at the ground pose) and k = K (the pose's own
settled start), all envs start there, with the run's training settings otherwise, the
assistance off and episodes of ``--seconds``; the share that stands up (CoM above
0.85 m, torso within 72°, for 1 s) says how far back along the move each actor rises.

    python research/probe_rise_levels.py runs/run_a --rises rises/sitting.npz --envs 32
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from hybrid_recovery.training.export import actor_from_checkpoint
from hybrid_recovery.training.probe import first_episodes, training_env


def probe(run: Path, rises: Path, levels: int, num_envs: int, seed: int,
          seconds: float) -> dict:
    """Stand-up share of ``run``'s latest actor from each level of ``rises``' starts."""
    env, data = training_env(run, num_envs, seed, {
        "rises.files": [str(rises)], "rises.levels": levels, "episode_length_s": seconds})
    (pose,) = env.rises.poses
    env.cfg.pose_weights = {pose: 1.0}  # every start from the recording's pose
    env.assist.fraction = 0.0
    actor = actor_from_checkpoint(data)
    shares = {}
    for k in range(levels + 1):
        env.rises.level[pose] = k
        stood, _ = first_episodes(env, actor)
        shares[f"{k}/{levels}"] = round(float(stood.mean()), 3)
    return {"run": str(run), "iteration": int(data["iter"]), "pose": pose,
            "episodes": num_envs, "seconds": seconds, "stood_up_by_level": shares}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--rises", type=Path, nargs="+", required=True,
                        help="recordings of `hybrid-recovery getup record`")
    parser.add_argument("--levels", type=int, default=8)
    parser.add_argument("--envs", type=int, default=32, help="episodes per level and run")
    parser.add_argument("--seconds", type=float, default=8.0, help="episode length [s]")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    torch.set_num_threads(1)
    for run in args.runs:
        for rises in args.rises:
            print(json.dumps(probe(run, rises, args.levels, args.envs, args.seed,
                                   args.seconds)), flush=True)


if __name__ == "__main__":
    main()
