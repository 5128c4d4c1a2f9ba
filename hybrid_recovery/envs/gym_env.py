"""A single-robot Gymnasium view of :class:`RecoveryEnv` (for tools outside rsl-rl).

``observation`` is the actor's noisy observation o_t (87); ``info["critic"]`` carries the
critic's (104, or 87 with ``privileged_critic=False``). ``terminated`` is an early
termination (torso contact, stuck low, a simulation failure), ``truncated`` the timeout.
The observation returned with either is the episode's last one; the next episode starts
at :meth:`RecoveryGymEnv.reset`.
"""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np
import torch
from gymnasium import spaces
from tensordict import TensorDict

from hybrid_recovery.envs.config import EnvConfig, default_config
from hybrid_recovery.envs.recovery_env import RecoveryEnv
from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.robot.action import ACTION_CLIP
from hybrid_recovery.robot.constants import NUM_JOINTS
from hybrid_recovery.sim.initial_states import POSES

if TYPE_CHECKING:
    from hybrid_recovery.sim.render import BalanceRenderer

ACTION_BOUND = ACTION_CLIP
"""|a| the environment accepts per joint; larger actions are clipped to it."""


class _LastObservationEnv(RecoveryEnv):
    """RecoveryEnv that keeps the observation of the step that ended an episode.

    ``RecoveryEnv.step`` logs finished episodes and then resets them in place; the
    observation built in that logging hook is the terminal one.
    """

    terminal_obs: TensorDict | None = None

    def _episode_log(self, ids: np.ndarray, dones_by: dict[str, np.ndarray]) -> dict:
        self.terminal_obs = self._observations()
        return super()._episode_log(ids, dones_by)


class RecoveryGymEnv(gym.Env):
    """One H1-2 recovery episode at a time, as a ``gymnasium.Env``.

    Args:
        cfg: environment configuration (``num_envs`` and ``num_threads`` are set to 1);
            None for :func:`hybrid_recovery.envs.default_config`.
        render_mode: None or ``"rgb_array"`` (OpenGL where a context can be made, else
            software; see :mod:`hybrid_recovery.sim.render`).

    Raises:
        ValueError: an unknown render mode.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 25}

    def __init__(self, cfg: EnvConfig | None = None, render_mode: str | None = None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or one of "
                             f"{self.metadata['render_modes']}, got {render_mode!r}")
        cfg = copy.deepcopy(cfg) if cfg is not None else default_config()
        cfg.num_envs, cfg.num_threads = 1, 1
        self.env = _LastObservationEnv(cfg)
        self.render_mode = render_mode
        self.observation_space = spaces.Box(-np.inf, np.inf, (ACTOR_OBS_DIM,), np.float32)
        self.action_space = spaces.Box(-ACTION_BOUND, ACTION_BOUND, (NUM_JOINTS,), np.float32)
        self._renderer: BalanceRenderer | None = None
        self._ids = np.zeros(1, dtype=int)

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Starts an episode.

        Args:
            seed: seeds the start state, noise and episode parameters.
            options: ``{"pose": name}`` forces the start pose of this episode.

        Returns:
            (o_0 (87,) float32, {"critic": critic observation}).

        Raises:
            ValueError: an unknown pose, or one the curriculum's current stage does not
                start from (stage 1: standing, squatting, kneeling).
        """
        super().reset(seed=seed)
        env = self.env
        env.rng = self.np_random
        pose = (options or {}).get("pose")
        weights = env.cfg.pose_weights
        if pose is not None:
            if pose not in POSES:
                raise ValueError(f"unknown pose '{pose}': choose one of {list(POSES)}")
            env.cfg.pose_weights = {pose: 1.0}
        try:
            env._reset(self._ids)
        finally:
            env.cfg.pose_weights = weights
        env._read_state(self._ids)
        env._obs = obs = env._observations()
        return self._policy(obs), {"critic": self._critic(obs)}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        """Advances one control step (20 ms).

        Args:
            action: a_t (27,), joint targets q* + 0.3 a_t (clipped to ±ACTION_BOUND).

        Returns:
            (o_t+1, r_t, terminated, truncated, info): info holds ``"critic"`` and, when
            the episode ended, ``"episode"`` (its ``reward/*`` and ``termination/*`` log).

        Raises:
            ValueError: an action of the wrong shape.
        """
        action = np.asarray(action, dtype=np.float32)
        if action.shape != (NUM_JOINTS,):
            raise ValueError(f"action must have shape ({NUM_JOINTS},), got {action.shape}")
        env = self.env
        env.terminal_obs = None
        obs, reward, done, extras = env.step(torch.from_numpy(action[None].copy()))
        truncated = bool(extras["time_outs"][0])
        terminated = bool(done[0]) and not truncated
        info: dict[str, Any] = {}
        if done[0]:
            obs = env.terminal_obs if env.terminal_obs is not None else obs
            info["episode"] = {k: float(np.asarray(v).reshape(-1)[0])
                               for k, v in extras["log"].items()}
        info["critic"] = self._critic(obs)
        return self._policy(obs), float(reward[0]), terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """The current frame with the balance overlay, (480, 640, 3) uint8."""
        if self.render_mode != "rgb_array":
            return None
        from hybrid_recovery.sim.render import BalanceRenderer, balance_overlay

        env = self.env
        if self._renderer is None:
            self._renderer = BalanceRenderer(env.cfg.model_path)
        model, data = env.sims.get_model(0), env.sims.get_data(0)
        overlay = balance_overlay(model, data, env.applied_push(0))
        return self._renderer.frame(data.qpos, overlay, env.dt)

    def close(self) -> None:
        """Releases the renderer's OpenGL context, if one was made."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    @staticmethod
    def _policy(obs: TensorDict) -> np.ndarray:
        return obs["policy"][0].numpy().copy()

    @staticmethod
    def _critic(obs: TensorDict) -> np.ndarray:
        return obs["critic"][0].numpy().copy()
