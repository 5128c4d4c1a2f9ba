"""``bench terms``: the MDP's per-step terms on numpy arrays (the CPU path, float64) and
on torch tensors (float32, MuJoCo Warp's precision, on the CPU or a GPU), from the same
simulation arrays of a stepped environment, in the same run."""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.timing import device_sync
from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.envs.config import RewardConfig
from hybrid_recovery.envs.rewards import compute_rewards
from hybrid_recovery.envs.step_state import (
    StepIndices,
    privileged_observation,
    read_step_state,
    reward_state,
)
from hybrid_recovery.envs.terminations import success_step, upright
from hybrid_recovery.observation.actor import actor_observation

PARTS = ("state_and_hulls", "rewards", "observations")
"""The timed parts of a control step's terms."""


def step_terms(a: Mapping[str, Array], at: StepIndices, dt: float, rewards: RewardConfig,
               h_star: float, timed: Callable[[str], object] | None = None
               ) -> dict[str, Array]:
    """Every per-step term of the MDP from the simulation arrays ``a`` (numpy or torch):
    ``state/<name>`` (:func:`read_step_state`), ``reward/<term>`` and ``reward``, ``actor``,
    ``privileged``, ``upright`` and ``success_time``.

    Args:
        a: sensordata, xmat, qpos, qvel, actuator_force, mass, prev_momentum,
            prev_com_vel, joint_range, velocity_limit, action, last_action, terminated,
            upright_time.
        timed: called with each part's name (:data:`PARTS`) when it is done.
    """
    mark = timed or (lambda part: None)
    s = read_step_state(a["sensordata"], a["xmat"], a["qpos"], a["qvel"], a["actuator_force"],
                        a["mass"], a["prev_momentum"], a["prev_com_vel"], at, dt)
    mark("state_and_hulls")
    total, parts = compute_rewards(
        reward_state(s, a["joint_range"], a["velocity_limit"], a["action"], a["last_action"],
                     a["terminated"]),
        rewards, h_star, dt)
    mark("rewards")
    out = {f"state/{k}": v for k, v in s.items()}
    out |= {f"reward/{k}": v for k, v in parts.items()} | {"reward": total}
    out["actor"] = actor_observation(s["gyro"], s["quat"], s["q"], s["dq"], a["action"])
    out["privileged"] = privileged_observation(s, a["qpos"][:, :2])
    out["upright"] = upright(s["height"], s["height_vel"], s["gravity_b"])
    out["success_time"] = success_step(a["upright_time"], s, dt)
    mark("observations")
    return out


def env_arrays(env, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """A stepped :class:`~hybrid_recovery.envs.RecoveryEnv`'s simulation arrays and MDP
    inputs (copies), with perturbed momentum histories and random terminations and
    standing times, as :func:`step_terms` takes them."""
    n = env.num_envs
    return dict(
        sensordata=env.sims.bind("sensordata").copy(), xmat=env.xmat.copy(),
        qpos=env.qpos.copy(), qvel=env.qvel.copy(),
        actuator_force=env.sims.bind("actuator_force").copy(),
        mass=env.randomizer.mass[:, 1:].sum(1),
        prev_momentum=env.prev_momentum + rng.normal(0.0, 1.0, env.prev_momentum.shape),
        prev_com_vel=env.prev_com_vel + rng.normal(0.0, 0.1, env.prev_com_vel.shape),
        joint_range=env.randomizer.jnt_range[:, 1:1 + env.num_actions].copy(),
        velocity_limit=np.asarray(env.velocity_limit).copy(),
        action=env.action.copy(), last_action=env.last_action.copy(),
        terminated=rng.random(n) < 0.3, upright_time=rng.uniform(0.0, 1.0, n))


def run_terms_bench(n: int = 4096, repeat: int = 5, seed: int = 0, device: str = "cpu",
                    steps: int = 10) -> BenchResult:
    """Times :func:`step_terms` on numpy and on torch float32 tensors on ``device``.

    The arrays are those of ``n`` envs at full difficulty after ``steps`` control steps of
    random actions; the tensors are made once (as views of a GPU simulation would be).
    Best of ``repeat`` each; a GPU is synchronised at every part's end.
    """
    import torch

    from hybrid_recovery.envs import RecoveryEnv, default_config

    if device == "cuda" and not torch.cuda.is_available():
        raise ValueError("device 'cuda' needs a CUDA GPU, and torch finds none")
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = n, 2, seed
    cfg.curriculum.enabled = False  # every pose, full randomisation, pushes
    env = RecoveryEnv(cfg)
    gen = torch.Generator().manual_seed(seed)
    for _ in range(steps):
        env.step(torch.randn(n, env.num_actions, generator=gen) * 0.5)
    arrays = env_arrays(env, np.random.default_rng(seed))
    tensors = {k: torch.as_tensor(v, device=device) for k, v in arrays.items()}
    tensors = {k: v.float() if v.is_floating_point() else v for k, v in tensors.items()}
    sync = device_sync(device) or (lambda: None)
    best: dict[str, dict[str, float]] = {}
    runs: tuple[tuple[str, Mapping[str, Any]], ...] = (("numpy", arrays), ("torch", tensors))
    for name, inputs in runs:
        for _ in range(repeat):
            marks: dict[str, float] = {}

            def timed(part: str, marks: dict[str, float] = marks) -> None:
                sync()
                marks[part] = time.perf_counter()

            sync()
            start = time.perf_counter()
            step_terms(inputs, env._at, env.dt, env.cfg.rewards, env.h_star, timed)
            times = dict(zip(PARTS, np.diff([start, *(marks[p] for p in PARTS)]), strict=True))
            if name not in best or sum(times.values()) < sum(best[name].values()):
                best[name] = {part: float(t) for part, t in times.items()}
    total = {name: sum(parts.values()) for name, parts in best.items()}
    rows = [(part, best["numpy"][part] * 1e3, best["torch"][part] * 1e3) for part in PARTS]
    rows.append(("all", total["numpy"] * 1e3, total["torch"] * 1e3))
    load = os.getloadavg()[0]
    return BenchResult(
        name="terms", title=f"per-step terms of {n} envs: numpy float64 vs torch float32 on "
        f"{device}, best of {repeat} (load average {load:.2f})",
        columns=("part", "numpy ms", f"torch ms ({device})"), rows=rows,
        figures={"num_envs": n, "device": device, "torch_threads": torch.get_num_threads(),
                 "numpy_ms": round(total["numpy"] * 1e3, 3),
                 "torch_ms": round(total["torch"] * 1e3, 3),
                 "ratio": round(total["numpy"] / total["torch"], 3),
                 "ms": {name: {p: round(t * 1e3, 3) for p, t in parts.items()}
                        for name, parts in best.items()},
                 "loadavg_1min": round(load, 2)})
