"""Unassisted rises from states along assisted stand-ups, for several checkpoints.

Collects the replay buffer of a run's training env (its own policy, stochastic, as in
training), then starts every env of a fresh env from a buffered state, without
assistance, and lets each checkpoint's deterministic actor play one episode:
the share that stands up (CoM above 0.85 m, torso within 72°, for 1 s) measures the
unaided part of a rise each policy can finish, on the same start states for all.

    python training/probe_replay_starts.py runs/full_replay runs/full_se --states 256
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch

from hybrid_recovery.sim.initial_states import POSES
from hybrid_recovery.training.export import actor_from_checkpoint
from hybrid_recovery.training.probe import first_episodes, training_env


def collect(run: Path, states: int, seed: int) -> dict[str, np.ndarray]:
    """Buffered states of ``run``'s training env once it holds ``states`` of them."""
    env, data = training_env(run, 256, seed)
    if not env.replay.active:
        raise ValueError(f"{run} does not use start-state replay (replay.fraction = 0)")
    actor = actor_from_checkpoint(data)
    obs = env.get_observations()
    steps = 0
    while env.replay.size < states:
        with torch.no_grad():
            obs, *_ = env.step(actor(obs, stochastic_output=True))
        steps += 1
        if steps % 250 == 0:
            print(f"  {steps} steps, {env.replay.size} states", flush=True)
    n = env.replay.size
    return {"qpos": env.replay.qpos[:n], "qvel": env.replay.qvel[:n], "pose": env.replay.pose[:n]}


def probe(run: Path, buffer: dict[str, np.ndarray], num_envs: int, seed: int) -> dict:
    """Deterministic unassisted episodes of ``run``'s latest actor from buffered states."""
    env, data = training_env(run, num_envs, seed)
    env.replay.cfg.fraction = 1.0  # every reset from the buffer
    env.assist.fraction = 0.0
    n = len(buffer["pose"])
    env.replay.qpos[:n], env.replay.qvel[:n], env.replay.pose[:n] = (
        buffer["qpos"], buffer["qvel"], buffer["pose"])
    env.replay.size = n
    stood, pose = first_episodes(env, actor_from_checkpoint(data))
    by_pose = {POSES[k]: f"{stood[pose == k].mean():.3f} of {int((pose == k).sum())}"
               for k in np.unique(pose)}
    return {"run": str(run), "iteration": int(data["iter"]), "stood_up": float(stood.mean()),
            "episodes": num_envs, "by_pose": by_pose}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("source", type=Path,
                        help="a run with replay on: where the states come from")
    parser.add_argument("runs", type=Path, nargs="*", help="more runs to probe on the same states")
    parser.add_argument("--states", type=int, default=256)
    parser.add_argument("--envs", type=int, default=256, help="episodes per run")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    torch.set_num_threads(1)
    buffer = collect(args.source, args.states, args.seed)
    print(f"{len(buffer['pose'])} states from {args.source}: "
          f"{ {POSES[k]: int((buffer['pose'] == k).sum()) for k in np.unique(buffer['pose'])} }")
    for run in [args.source, *args.runs]:
        print(json.dumps(probe(run, buffer, args.envs, args.seed + 1)), flush=True)


if __name__ == "__main__":
    main()
