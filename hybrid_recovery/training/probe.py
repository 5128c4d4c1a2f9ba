"""Probes of a run's actor in its own training env: deterministic, unassisted episodes
from chosen start states (the research scripts build on these)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDict

from hybrid_recovery.envs import RecoveryEnv, apply_overrides
from hybrid_recovery.sim.initial_states import POSES
from hybrid_recovery.training.checkpoint import LATEST, load_checkpoint, read_run_config
from hybrid_recovery.training.config import train_config_from_dict
from hybrid_recovery.training.export import actor_from_checkpoint
from hybrid_recovery.training.runner import make_env_config


def heading_xy(xmat: np.ndarray) -> np.ndarray:
    """Headings: the unit horizontal direction of bodies' x axes.

    Args:
        xmat: world rotations R, row-major, shape (N, 9).

    Returns:
        (R_xx, R_yx) normalised, shape (N, 2); (1, 0) for an x axis pointing straight up
        or down.
    """
    axis = np.asarray(xmat, dtype=float)[:, [0, 3]]
    norm = np.linalg.norm(axis, axis=1, keepdims=True)
    return np.where(norm > 1e-9, axis / np.maximum(norm, 1e-9), [1.0, 0.0])


def training_env(run: Path, num_envs: int, seed: int,
                 overrides: dict | None = None) -> tuple[RecoveryEnv, dict]:
    """``run``'s training env (its config, curriculum and assistance state at its latest
    checkpoint, any pose from the first reset on) and that checkpoint.

    Args:
        overrides: dotted EnvConfig keys set before the env is built.
    """
    data = load_checkpoint(run / LATEST)
    cfg = train_config_from_dict(read_run_config(run)["train_config"])
    cfg.num_envs, cfg.num_threads, cfg.seed = num_envs, 1, seed
    env_cfg = make_env_config(cfg)
    env_cfg.curriculum.stage1_poses = tuple(POSES)
    apply_overrides(env_cfg, overrides or {})
    env = RecoveryEnv(env_cfg)
    env.curriculum.load_state_dict(data["infos"]["curriculum"])
    env.assist.load_state_dict(data["infos"]["assist"])
    return env, data


def bridge_env(run: Path, num_envs: int, seed: int, levels: int, source: str,
               target: str) -> tuple[RecoveryEnv, torch.nn.Module, dict]:
    """``run``'s training env with one bridge, ``source`` → ``target`` in ``levels`` steps,
    every start drawn for ``target`` at the bridge's current level and no
    assistance; with the run's latest actor and checkpoint."""
    env, data = training_env(run, num_envs, seed, {
        "bridge.levels": levels, "bridge.pairs": [[source, target]],
        "pose_weights": {target: 1.0}})
    env.assist.fraction = 0.0
    return env, actor_from_checkpoint(data), data


def ended_episodes(dones: torch.Tensor, extras: dict) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The episodes one ``env.step`` ended, in the order of its episode log: env ids (E,),
    stood up (E,) bool, and each one's termination causes joined by ", " ("" if none)."""
    ids = np.flatnonzero(dones.numpy())
    log = extras["log"]
    stood = log["episode/stood_up"].numpy() > 0 if len(ids) else np.zeros(0, bool)
    flags = {key.split("/", 1)[1]: value.numpy() for key, value in log.items()
             if key.startswith("termination/")} if len(ids) else {}
    causes = [", ".join(name for name, v in flags.items() if v[k] > 0) for k in range(len(ids))]
    return ids, stood, causes


def start_episodes(env: RecoveryEnv) -> TensorDict:
    """Resets every env to a new start (of the current levels) and returns the first
    observations."""
    ids = np.arange(env.num_envs)
    env._reset(ids)
    env._read_state(ids)
    env._obs = env._observations()
    return env.get_observations()


def first_episodes(env: RecoveryEnv, actor: torch.nn.Module,
                   watch: Callable[[np.ndarray], None] | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Resets every env and plays the deterministic ``actor`` until each has ended one
    episode. ``watch(live)``, if given, sees the env after the reset and after every
    step, ``live`` (N,) bool marking the envs whose state is still their first episode's
    (an env reset by the step is not). Returns (stood up (N,) bool, start pose index into
    ``POSES`` (N,))."""
    n = env.num_envs
    obs = start_episodes(env)
    done, stood = np.zeros(n, bool), np.zeros(n, bool)
    pose = env.start_pose.copy()
    if watch is not None:
        watch(np.ones(n, bool))
    while not done.all():
        with torch.no_grad():
            obs, _, dones, extras = env.step(actor(obs))
        ended, up, _ = ended_episodes(dones, extras)
        first = ~done[ended]
        stood[ended[first]] = up[first]
        done[ended] = True
        if watch is not None:
            watch(~done)
    return stood, pose
