"""``play``: one episode of the recovery environment rendered to an MP4.

The controller is zero actions (PD targets at the default pose) or an exported ONNX
policy fed the actor observation, as in training. Frames come from
:class:`hybrid_recovery.sim.render.BalanceRenderer` with the balance overlay.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.files import atomic_path
from hybrid_recovery.policy import OnnxPolicy
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.divergence import SimulationDiverged
from hybrid_recovery.sim.render import BalanceRenderer, balance_overlay

CONTROL_RATE = 50
"""Control steps per second of the environment [Hz]; the frame rate must divide it."""

Policy = Callable[[np.ndarray], np.ndarray]
"""Actor observation (N, 87) float32 → action (N, 27) float32."""


def onnx_policy(path: str | Path) -> Policy:
    """An exported policy (``policy.onnx``, or the directory holding it) on onnxruntime.

    ``policy.json`` next to it, when present, is checked (:class:`OnnxPolicy`).

    Raises:
        FileNotFoundError: no such file.
        ValueError: the policy does not match this robot or observation layout.
    """
    policy = OnnxPolicy(path)

    def act(obs: np.ndarray) -> np.ndarray:
        return policy.act(obs).astype(np.float32)

    return act


def zero_policy(obs: np.ndarray) -> np.ndarray:
    """Zero actions: PD targets at the default pose."""
    return np.zeros((len(obs), constants.NUM_JOINTS), np.float32)


def play(out: str | Path, pose: str = "standing", seconds: float = 5.0,
         policy: Policy | None = None, push: float = 0.0, push_angle: float = 0.0,
         push_time: float = 1.0, push_duration: float = 0.1, fps: int = 25,
         width: int = 640, height: int = 480, seed: int = 0, randomize: bool = False,
         model_path: str | Path | None = None) -> int:
    """Renders one episode of the recovery environment to an MP4.

    The episode runs at the final curriculum settings (hardware torque limits, 0.9×
    position limits) with the paper's start-state noise, but without terminations or
    random pushes, so the video is one continuous take; physics parameters are nominal
    unless ``randomize``.

    Args:
        out: the .mp4 file to write.
        pose: start pose, one of :data:`hybrid_recovery.sim.initial_states.POSES`.
        seconds: episode length [s].
        policy: actor observation → action; None for zero actions.
        push: torso push |F| [N] (0: none), at ``push_time`` [s] for ``push_duration`` [s].
        push_angle: push direction in the robot's heading frame [deg]: 0 pushes forward
            (from behind), 90 to the robot's left.
        fps: frames per second, a divisor of the 50 Hz control rate (25 or 50).
        width, height: frame size [px].
        seed: seeds the start state.
        randomize: domain-randomised physics (the training ranges) instead of nominal.
        model_path: robot MJCF; None for the project's H1-2.

    Returns:
        The number of frames written.

    Raises:
        ValueError: an unknown pose, a frame rate that does not divide 50, or seconds ≤ 0.
        SimulationDiverged: the simulation diverged (the environment reset it); the
            video up to then is written.
    """
    import imageio.v2 as imageio
    import torch

    from hybrid_recovery.envs import RecoveryEnv, default_config
    from hybrid_recovery.sim.initial_states import POSES

    if pose not in POSES:
        raise ValueError(f"unknown pose '{pose}': choose one of {list(POSES)}")
    if fps <= 0 or CONTROL_RATE % fps:
        raise ValueError(f"fps must divide the {CONTROL_RATE} Hz control rate "
                         f"(25 or 50), got {fps}")
    if not seconds > 0:
        raise ValueError(f"seconds must be > 0, got {seconds}")
    cfg = _play_config(default_config(), pose, seconds, seed, model_path)
    env = RecoveryEnv(cfg)
    if not randomize:
        env.randomizer.randomize(np.array([0]), env.rng, 0.0)
    policy = policy or zero_policy
    renderer = BalanceRenderer(model_path, width, height)
    sim_model = copy.copy(env.model)
    sim_data = mujoco.MjData(env.model)
    every = CONTROL_RATE // fps
    steps = int(round(seconds / env.dt))
    push_step = int(round(push_time / env.dt)) if push > 0 else -1
    obs = env.get_observations()
    frames = 0
    diverged_at = None
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp, imageio.get_writer(
            str(tmp), fps=fps, codec="libx264", quality=7, macro_block_size=16,
            ffmpeg_log_level="error") as writer:  # a stopped take leaves no half a video
        for k in range(steps):
            if env.nan_resets:  # the env restarted a diverged episode: the take ends
                diverged_at = k * env.dt
                break
            if k == push_step:
                _start_push(env, push, push_angle, push_duration)
            if k % every == 0:
                env.sims.get_model(0, sim_model)
                env.sims.get_data(0, sim_data)
                overlay = balance_overlay(sim_model, sim_data, env.applied_push(0))
                frame = renderer.frame(sim_data.qpos, overlay, every * env.dt)
                writer.append_data(frame)  # type: ignore[attr-defined]
                frames += 1
            action = policy(obs["policy"].numpy())
            obs, *_ = env.step(torch.as_tensor(np.asarray(action, np.float32)))
    renderer.close()
    if diverged_at is not None:
        raise SimulationDiverged(
            f"the simulation diverged at t = {diverged_at:.2f} s (unstable physics or a "
            f"non-finite action) and the environment restarted it; the video {out} stops "
            f"there ({frames} frames)")
    return frames


def _play_config(cfg, pose: str, seconds: float, seed: int, model_path):
    cfg.num_envs, cfg.num_threads, cfg.seed, cfg.model_path = 1, 1, seed, model_path
    cfg.curriculum.enabled = False
    cfg.pose_weights = {pose: 1.0}
    cfg.episode_length_s = seconds + 1.0
    cfg.stuck_time = math.inf
    cfg.torso_force_limit = math.inf
    cfg.pushes.interval = (1e9, 1e9)  # only the requested push
    return cfg


def _start_push(env, force: float, angle_deg: float, duration: float) -> None:
    """Schedules a push on env 0 through its push schedule, in its heading frame."""
    w, x, y, z = env.qpos[0, 3:7]
    heading = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    direction = heading + math.radians(angle_deg)
    env.pushes.current[0] = (force * math.cos(direction), force * math.sin(direction), 0.0)
    env.pushes.remaining[0] = duration + env.dt / 2  # applied for round(duration / dt) steps
