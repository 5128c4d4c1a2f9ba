"""``bench train``: end-to-end PPO env steps/s against the physics-only rate, and where the
time goes, down to the parts of the PPO update."""

from __future__ import annotations

import contextlib
import io
import os
import time
from collections import defaultdict
from dataclasses import fields, replace
from typing import Any, get_type_hints

from hybrid_recovery.bench.env import _timed
from hybrid_recovery.bench.physics_replay import PhysicsReplay
from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.timing import device_sync
from hybrid_recovery.bench.update_parts import fill_storage, ratio_noise, time_update_parts


def bench_train_config(n: int, seed: int, threads: int, overrides: dict[str, Any] | None,
                       backend: str = "batch", device: str = "cpu"):
    """The bench's TrainConfig: ``n`` envs, ``threads`` physics and torch threads, then
    ``overrides``: ``ppo.<field>`` keys set PPO settings, other keys TrainConfig fields
    (e.g. ``torch_threads=1``, ``ppo.mixed_precision=true``; unset, the
    precision is chosen by the machine as in training).

    Raises:
        KeyError: naming an unknown setting.
        ValueError: ``config key 'train.<field>' must be ..., got ...`` (or ``ppo.<field>``).
    """
    from hybrid_recovery.envs.config_values import checked_value
    from hybrid_recovery.training.config import PPOConfig, TrainConfig

    top: dict[str, Any] = {}
    ppo: dict[str, Any] = {}
    for key, value in (overrides or {}).items():
        group, name = (ppo, key.removeprefix("ppo.")) if key.startswith("ppo.") else (top, key)
        cls = PPOConfig if group is ppo else TrainConfig
        known = {f.name for f in fields(cls)} - {"ppo"}
        if name not in known:
            raise KeyError(f"unknown training setting '{key}'; known: {sorted(known)} "
                           f"(PPO settings as ppo.<name>)")
        dotted = key if group is ppo else f"train.{key}"
        group[name] = checked_value(dotted, value, get_type_hints(cls)[name])
    cfg = TrainConfig(num_envs=n, seed=seed, num_threads=threads, backend=backend, device=device)
    return replace(cfg, **top, ppo=replace(cfg.ppo, **ppo))


def run_train_bench(n: int = 1024, repeat: int = 2, seed: int = 0, threads: int = 2,
                    overrides: dict[str, Any] | None = None, backend: str = "batch",
                    device: str = "cpu") -> BenchResult:
    """Runs ``repeat`` PPO iterations (24 steps × n envs each) without logging.

    Splits an iteration into simulation (physics substeps), observation/reward work
    (state, hulls, observations, rewards, resets), policy inference and storage, and the
    PPO update; replays the same iterations' controls and pushes on the bare Batch for the
    physics-only rate (as ``bench env``), so ``ratio`` = end-to-end / physics-only env
    steps per second; then times the update's parts on one more rollout
    (:func:`~hybrid_recovery.bench.update_parts.time_update_parts`; ``rest`` is the
    update's wall time less its parts timed one by one, negative where the critic's half
    runs beside the actor's, :mod:`~hybrid_recovery.training.split_update`) and the PPO
    ratio's rounding noise in the update's precision
    (:func:`~hybrid_recovery.bench.update_parts.ratio_noise`).

    Args:
        overrides: TrainConfig settings, see :func:`bench_train_config`.
        backend, device: the physics backend and device (``cuda``: the learner too).
    """
    import torch

    from hybrid_recovery.envs import RecoveryEnv
    from hybrid_recovery.training.config import runner_dict
    from hybrid_recovery.training.distributed import Rank
    from hybrid_recovery.training.runner import (
        RecoveryRunner,
        make_env_config,
        update_precision,
    )

    cfg = bench_train_config(n, seed, threads, overrides, backend, device)
    torch_threads = cfg.torch_threads or cfg.num_threads
    torch.set_num_threads(torch_threads)
    env = RecoveryEnv(make_env_config(cfg))
    precision = update_precision(cfg, int(env.get_observations()["critic"].shape[1]),
                                 env.num_actions)
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the networks
        runner = RecoveryRunner(env, runner_dict(cfg, precision), None, meta={},
                                device=Rank().learner_device(cfg.device))
    totals: dict[str, float] = defaultdict(float)
    sync = device_sync(cfg.device)
    _timed(env, "step", totals, sync)
    _timed(env, "_physics", totals, sync)
    _timed(runner.alg, "update", totals, sync)
    replay = PhysicsReplay(env)
    runner.learn(1)  # warm-up
    totals.clear()
    replay.start()
    t = time.perf_counter()
    runner.learn(repeat)
    wall = time.perf_counter() - t
    physics_only = replay.replay()
    steps = repeat * cfg.num_steps_per_env * n
    split = {"simulation": totals["_physics"],
             "observation_reward": totals["step"] - totals["_physics"],
             "policy_inference_and_storage": wall - totals["step"] - totals["update"],
             "ppo_update": totals["update"]}
    fill_storage(runner)
    noise = ratio_noise(runner.alg)
    parts = time_update_parts(runner.alg, repeat)
    parts["rest"] = totals["update"] / repeat - sum(parts.values())
    runner.alg.storage.clear()
    rows = [(k, v / repeat, v / wall) for k, v in split.items()]
    rows += [(f"  {k}", v, v * repeat / wall) for k, v in parts.items()]
    load = os.getloadavg()[0]
    env_rate, physics_rate = steps / wall, steps / physics_only
    ppo = cfg.ppo
    settings = {"backend": cfg.backend, "device": cfg.device,
                "threads": cfg.num_threads, "torch_threads": torch_threads,
                "mixed_precision": precision.mixed_precision,
                "precision_choice": precision.reason,
                "num_learning_epochs": ppo.num_learning_epochs,
                "num_mini_batches": ppo.num_mini_batches, "symmetry": ppo.symmetry,
                "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY")}
    return BenchResult(
        name="train", title=f"PPO iteration, {n} envs × {cfg.num_steps_per_env} steps, "
        f"{cfg.num_threads} physics / {torch_threads} torch threads, "
        f"{ppo.num_learning_epochs} epochs × {ppo.num_mini_batches} mini-batches, "
        f"update {precision.reason} (load average {load:.2f}); "
        f"end to end {env_rate:.0f} env steps/s, physics only {physics_rate:.0f}",
        columns=("part", "s per iteration", "share"), rows=rows,
        figures={"num_envs": n, "env_steps_per_s": round(env_rate, 1),
                 "physics_steps_per_s": round(physics_rate, 1),
                 "ratio": round(env_rate / physics_rate, 3),
                 "s_per_iteration": {k: round(v / repeat, 3) for k, v in split.items()},
                 "update_s_per_iteration": {k: round(v, 3) for k, v in parts.items()},
                 "ratio_noise_at_start": round(noise, 4),
                 "settings": settings, "loadavg_1min": round(load, 2)})
