"""``bench env``: env steps/s with random actions vs the physics-only rate, same run."""

from __future__ import annotations

import os
import time
from collections import defaultdict
from collections.abc import Callable

from hybrid_recovery.bench.physics_replay import PhysicsReplay
from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.timing import device_sync


def _timed(obj, name: str, totals: dict, sync: Callable[[], None] | None = None) -> None:
    """Wraps ``obj.name`` to accumulate its wall time in ``totals[name]``; with ``sync``
    (a GPU's ``torch.cuda.synchronize``) the time runs until the work it queued is done,
    not only launched."""
    fn = getattr(obj, name)

    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            if sync is not None:
                sync()
            totals[name] += time.perf_counter() - t

    setattr(obj, name, wrapper)


def _physics_name(cfg, threads: int) -> str:
    """The physics of a bench run, for its title."""
    if cfg.backend == "batch":
        return f"{threads} physics threads"
    return f"MuJoCo Warp on {cfg.device}"


def run_env_bench(n: int = 1024, repeat: int = 3, seed: int = 0, steps: int = 50,
                  threads: int = 2, overrides: dict | None = None, backend: str = "batch",
                  device: str = "cpu") -> BenchResult:
    """Times ``RecoveryEnv.step`` on ``n`` envs, then the bare Batch on the same states.

    The physics-only rate restores the Batch to the state the timed env run started from
    and replays the same controls and pushes, substeps and sensors, with no observation,
    reward, contact-hull or reset work: the same physics, step for step (envs the env run
    reset continue without the reset). ``backend``/``device`` choose the physics
    (:mod:`hybrid_recovery.sim.backend`); the JSON is the same for both. On a GPU each
    timed part ends with the device synchronised, so its work is counted in it.
    """
    import torch

    from hybrid_recovery.envs import RecoveryEnv, apply_overrides, default_config

    cfg = apply_overrides(default_config(), overrides or {})
    cfg.num_envs, cfg.num_threads, cfg.seed = n, threads, seed
    cfg.backend, cfg.device = backend, device
    env = RecoveryEnv(cfg)
    gen = torch.Generator().manual_seed(seed)
    actions = [torch.randn(n, 27, generator=gen) * 0.5 for _ in range(steps)]
    for a in actions[:5]:
        env.step(a)
    totals: dict[str, float] = defaultdict(float)
    sync = device_sync(device)
    for name in ("_physics", "_read_state", "_observations", "_reset"):
        _timed(env, name, totals, sync)
    best_env, best_phys = float("inf"), float("inf")
    best_totals: dict[str, float] = {}
    replay = PhysicsReplay(env)
    for _ in range(repeat):
        replay.start()
        totals.clear()
        t = time.perf_counter()
        for a in actions:
            env.step(a)
        elapsed = time.perf_counter() - t
        if elapsed < best_env:
            best_env, best_totals = elapsed, dict(totals)
        best_phys = min(best_phys, replay.replay())
    env_rate, phys_rate = steps * n / best_env, steps * n / best_phys
    totals = defaultdict(float, best_totals)
    other = best_env - sum(totals.values())
    split = {"physics": totals["_physics"], "state_and_hulls": totals["_read_state"],
             "observations": totals["_observations"], "resets": totals["_reset"],
             "rewards_terminations_other": other}
    rows = [(k, v / steps * 1e3, v / best_env) for k, v in split.items()]
    load = os.getloadavg()[0]
    return BenchResult(
        name="env", title=f"RecoveryEnv.step, {n} envs, {_physics_name(cfg, threads)}, "
        f"{steps} steps, physics {cfg.physics_dt * 1e3:g} ms × {cfg.decimation} "
        f"(load average {load:.2f})",
        columns=("part", "ms per step", "share"), rows=rows,
        figures={"num_envs": n, "backend": backend, "device": device,
                 "physics_dt": cfg.physics_dt, "env_steps_per_s": round(env_rate, 1),
                 "physics_steps_per_s": round(phys_rate, 1),
                 "ratio": round(env_rate / phys_rate, 3),
                 "ms_per_step": {k: round(v / steps * 1e3, 2) for k, v in split.items()},
                 "loadavg_1min": round(load, 2)})
