"""Probe: how long CPU MuJoCo (``batch``, float64) and MuJoCo Warp (``warp``, float32, the
CPU device) agree on a model file, by start pose.

Both environments are built from the same seed (the same starts, randomisation, pushes
and noise) at full difficulty with the constraint solver run to convergence (100
iterations, as in ``tests/test_warp_parity.py``), then stepped with the same random
actions; per control step it reports, for each start pose, the worst |Δqpos| [m or rad]
and |Δqvel| [m/s or rad/s] over that pose's worlds and the seeds, and the worst distance
[m] between the two backends' contact points in the slots both find active. A model
without joint armature (the manufacturer's mesh model) needs ``--physics-dt 0.001``.

    python research/probe_backend_parity.py --model PATH/h1_2_handless.xml \\
        --physics-dt 0.001 --seeds 1 2 3 --steps 6
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs import recovery_env as recovery_env_module
from hybrid_recovery.sim.initial_states import POSES
from hybrid_recovery.sim.scene import read_contacts

SOLVER_ITERATIONS = 100
"""Both solvers to convergence: at the model's cap the two stop at different iterates."""


def _converged_scene(*args, **kwargs):
    model, layout = _BUILD(*args, **kwargs)
    model.opt.iterations = SOLVER_ITERATIONS
    return model, layout


_BUILD = recovery_env_module.build_scene


def _env(backend: str, model: str | None, seed: int, num_envs: int, physics_dt: float
         ) -> RecoveryEnv:
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed, cfg.backend = num_envs, 1, seed, backend
    cfg.model_path, cfg.curriculum.enabled = model, False
    cfg.physics_dt = physics_dt
    cfg.decimation = int(round(0.02 / physics_dt))  # the 50 Hz control step
    recovery_env_module.build_scene = _converged_scene
    try:
        return RecoveryEnv(cfg)
    finally:
        recovery_env_module.build_scene = _BUILD


def parity(model: str | None, seeds: list[int], steps: int, num_envs: int,
           physics_dt: float) -> dict[str, np.ndarray]:
    """Per pose, the worst (Δqpos, Δqvel, Δcontact point) of each control step, (steps, 3)."""
    worst: dict[str, np.ndarray] = {}
    for seed in seeds:
        batch, warp = (_env(backend, model, seed, num_envs, physics_dt)
                       for backend in ("batch", "warp"))
        poses = np.asarray(POSES)[batch.start_pose]
        gen = torch.Generator().manual_seed(seed)
        for step in range(steps):
            actions = torch.randn(num_envs, 27, generator=gen) * 0.3
            batch.step(actions)
            warp.step(actions)
            dq = np.abs(batch.qpos - warp.qpos.astype(float)).max(axis=1)
            dv = np.abs(batch.qvel - warp.qvel.astype(float)).max(axis=1)
            active_b, _, points_b = read_contacts(batch.sims.bind("sensordata"), batch.layout)
            active_w, _, points_w = read_contacts(warp.sims.bind("sensordata"), warp.layout)
            both = active_b & active_w
            gap = np.where(both, np.linalg.norm(points_b - points_w, axis=-1), 0.0).max(axis=1)
            for pose in set(poses):
                mine = poses == pose
                row = np.array([dq[mine].max(), dv[mine].max(), gap[mine].max()])
                table = worst.setdefault(pose, np.zeros((steps, 3)))
                table[step] = np.maximum(table[step], row)
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", default=None, help="MJCF path (default: the project's)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--steps", type=int, default=6, help="control steps (50 Hz)")
    parser.add_argument("--num-envs", type=int, default=8)
    parser.add_argument("--physics-dt", type=float, default=0.005)
    args = parser.parse_args()
    worst = parity(args.model, args.seeds, args.steps, args.num_envs, args.physics_dt)
    print("| pose | " + " | ".join(f"step {k + 1}" for k in range(args.steps)) + " |")
    print("|---|" + "---|" * args.steps)
    for pose in POSES:
        if pose in worst:
            cells = [f"{q:.1e} / {v:.1e} / {c:.1e}" for q, v, c in worst[pose]]
            print(f"| {pose} | " + " | ".join(cells) + " |")
    print("cells: worst |Δqpos| / |Δqvel| / contact point distance")


if __name__ == "__main__":
    main()
