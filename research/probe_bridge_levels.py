"""Deterministic, unassisted rises of runs' actors from each level of a start-pose bridge.

For every level k = 0 … K of ``bridge.levels`` = K (k = K: the target pose itself), all
envs start from the target's pose at that level, with the run's training settings
otherwise and the assistance off; the share that stands up (CoM above 0.85 m, torso
within 72°, for 1 s) says how hard each blend is for each actor.

    python research/probe_bridge_levels.py runs/run_a runs/run_b --levels 8 --envs 64

``--torque-scale S`` multiplies the hardware effort limits by S (1 ≤ S ≤ the curriculum's
``torque_scale_explore``) through the torque curriculum's level, the actor unchanged (the
joint-range factor moves with that level: 0.90 at 1×, 0.91 at 2× with the defaults).
"""

from __future__ import annotations

import json
from pathlib import Path

import torch
from bridge_args import bridge_parser

from hybrid_recovery.training.probe import bridge_env, first_episodes


def probe(run: Path, levels: int, num_envs: int, seed: int, source: str,
          target: str, torque_scale: float = 1.0) -> dict:
    """Stand-up share of ``run``'s latest actor from each level of the bridge, with the
    effort limits × ``torque_scale``."""
    env, actor, data = bridge_env(run, num_envs, seed, levels, source, target)
    explore = env.curriculum.cfg.torque_scale_explore
    if not 1.0 <= torque_scale <= explore:
        raise ValueError(f"--torque-scale must be in [1, {explore}], got {torque_scale}")
    env.curriculum.stage = 3
    env.curriculum.level = (explore - torque_scale) / (explore - 1.0) if explore > 1.0 else 1.0
    shares = {}
    for k in range(levels + 1):
        env.bridge.level[target] = k
        stood, _ = first_episodes(env, actor)
        shares[f"{k}/{levels}"] = round(float(stood.mean()), 3)
    return {"run": str(run), "iteration": int(data["iter"]), "episodes": num_envs,
            "torque_scale": round(env.curriculum.torque_scale, 3), "stood_up_by_level": shares}


def main() -> None:
    parser = bridge_parser(__doc__.split("\n")[0])
    parser.add_argument("--torque-scale", type=float, default=1.0)
    args = parser.parse_args()
    torch.set_num_threads(1)
    for run in args.runs:
        print(json.dumps(probe(run, args.levels, args.envs, args.seed, args.source,
                               args.target, args.torque_scale)), flush=True)


if __name__ == "__main__":
    main()
