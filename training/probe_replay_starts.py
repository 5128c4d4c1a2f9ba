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

from hybrid_recovery.envs import RecoveryEnv
from hybrid_recovery.envs.initial_states import POSES
from hybrid_recovery.training.checkpoint import LATEST, load_checkpoint
from hybrid_recovery.training.config import train_config_from_dict
from hybrid_recovery.training.export import actor_from_checkpoint
from hybrid_recovery.training.runner import make_env_config


def _env(run: Path, num_envs: int, seed: int) -> tuple[RecoveryEnv, dict]:
    data = load_checkpoint(run / LATEST)
    cfg = train_config_from_dict(json.loads((run / "config.json").read_text())["train_config"])
    cfg.num_envs, cfg.num_threads, cfg.seed = num_envs, 1, seed
    env_cfg = make_env_config(cfg)
    env_cfg.curriculum.stage1_poses = tuple(POSES)  # any pose from the first reset on
    env = RecoveryEnv(env_cfg)
    env.curriculum.load_state_dict(data["infos"]["curriculum"])
    env.assist.load_state_dict(data["infos"]["assist"])
    return env, data


def collect(run: Path, states: int, seed: int) -> dict[str, np.ndarray]:
    """Buffered states of ``run``'s training env once it holds ``states`` of them."""
    env, data = _env(run, 256, seed)
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
    env, data = _env(run, num_envs, seed)
    env.replay.cfg.fraction = 1.0  # every reset from the buffer
    env.assist.fraction = 0.0
    n = len(buffer["pose"])
    env.replay.qpos[:n], env.replay.qvel[:n], env.replay.pose[:n] = (
        buffer["qpos"], buffer["qvel"], buffer["pose"])
    env.replay.size = n
    ids = np.arange(num_envs)
    env._reset(ids)
    env._read_state(ids)
    env._obs = env._observations()
    actor = actor_from_checkpoint(data)
    obs = env.get_observations()
    done, stood = np.zeros(num_envs, bool), np.zeros(num_envs, bool)
    pose = env.start_pose.copy()
    while not done.all():
        with torch.no_grad():
            obs, _, dones, extras = env.step(actor(obs))
        ended = np.flatnonzero(dones.numpy())  # the order of the episode log
        if not len(ended):
            continue
        first = ~done[ended]
        stood[ended[first]] = extras["log"]["episode/stood_up"].numpy()[first] > 0
        done[ended] = True
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
