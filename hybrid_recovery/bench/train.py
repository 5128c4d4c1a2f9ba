"""``bench train``: end-to-end PPO env steps/s and where the time goes."""

from __future__ import annotations

import os
import time
from collections import defaultdict

from hybrid_recovery.bench.env import _timed
from hybrid_recovery.bench.result import BenchResult


def run_train_bench(n: int = 1024, repeat: int = 2, seed: int = 0, threads: int = 2,
                    mini_batches: int = 4) -> BenchResult:
    """Runs ``repeat`` PPO iterations (24 steps × n envs each) without logging.

    Splits an iteration into simulation (physics substeps), observation/reward work
    (state, hulls, observations, rewards, resets), policy inference, and the PPO update.
    """
    import torch

    from hybrid_recovery.envs import RecoveryEnv
    from hybrid_recovery.training.config import TrainConfig, runner_dict
    from hybrid_recovery.training.runner import RecoveryRunner, make_env_config

    cfg = TrainConfig(num_envs=n, seed=seed, num_threads=threads)
    cfg.ppo.num_mini_batches = mini_batches
    torch.set_num_threads(threads)
    env = RecoveryEnv(make_env_config(cfg))
    runner = RecoveryRunner(env, runner_dict(cfg), None, meta={})
    totals: dict[str, float] = defaultdict(float)
    _timed(env, "step", totals)
    _timed(env, "_physics", totals)
    _timed(runner.alg, "update", totals)
    runner.learn(1)  # warm-up
    totals.clear()
    t = time.perf_counter()
    runner.learn(repeat)
    wall = time.perf_counter() - t
    steps = repeat * cfg.num_steps_per_env * n
    split = {"simulation": totals["_physics"],
             "observation_reward": totals["step"] - totals["_physics"],
             "policy_inference_and_storage": wall - totals["step"] - totals["update"],
             "ppo_update": totals["update"]}
    rows = [(k, v / repeat, v / wall) for k, v in split.items()]
    load = os.getloadavg()[0]
    return BenchResult(
        name="train", title=f"PPO iteration, {n} envs × 24 steps, {threads} threads, "
        f"{mini_batches} mini-batches (load average {load:.2f})",
        columns=("part", "s per iteration", "share"), rows=rows,
        figures={"num_envs": n, "env_steps_per_s": round(steps / wall, 1),
                 "s_per_iteration": {k: round(v / repeat, 3) for k, v in split.items()},
                 "loadavg_1min": round(load, 2)})
