"""Deterministic rises of runs' actors from start poses under a range of assistance
fractions f (f = 0: unassisted, as deployed).

For every pose and fraction all envs start from the pose itself (no bridge), with the run's
training settings and its torso pull at f, on every pose named; the share that stands up
(CoM above 0.85 m, torso within 72°, for 1 s) says how much of a rise each actor makes on
its own, and how much the assistance still carries.

    python research/probe_assisted_poses.py runs/my_run --poses supine sitting \
        --fractions 0 0.3 0.5 0.648 --envs 32
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from hybrid_recovery.training.export import actor_from_checkpoint
from hybrid_recovery.training.probe import first_episodes, training_env


def probe(run: Path, pose: str, fractions: list[float], num_envs: int, seed: int) -> dict:
    """Stand-up share of ``run``'s latest actor from ``pose`` at each assistance fraction
    (an unknown pose is refused by the env's own check of ``pose_weights``)."""
    if not all(0.0 <= f < 1.0 for f in fractions):
        raise ValueError(f"assistance fractions must be in [0, 1), got {fractions}")
    env, data = training_env(run, num_envs, seed, {
        "bridge.levels": 0, "bridge.pairs": [], "pose_weights": {pose: 1.0},
        "assist.poses": [pose]})
    actor = actor_from_checkpoint(data)
    shares = {}
    for f in fractions:
        env.assist.load_state_dict({"fraction": f, "outcomes": []})  # window emptied: no annealing
        stood, _ = first_episodes(env, actor)
        if env.assist.fraction != f:
            raise RuntimeError(f"the probe annealed its own assistance ({f} → "
                               f"{env.assist.fraction}); use fewer --envs than the window")
        shares[f"{f:g}"] = round(float(stood.mean()), 3)
    return {"run": str(run), "iteration": int(data["iter"]), "pose": pose,
            "episodes": num_envs, "stood_up_by_fraction": shares}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--poses", nargs="+", default=["supine"])
    parser.add_argument("--fractions", type=float, nargs="+", default=[0.0, 0.3, 0.5, 0.648])
    parser.add_argument("--envs", type=int, default=32, help="episodes per pose, fraction and run")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    torch.set_num_threads(1)
    for run in args.runs:
        for pose in args.poses:
            print(json.dumps(probe(run, pose, args.fractions, args.envs, args.seed)), flush=True)


if __name__ == "__main__":
    main()
