"""One policy step, the same for every runner: o_t → π → clip → q_ref.

The controller on the torque model, the evaluation's policy controller and the robot's
policy runner all call :func:`policy_step`, so the observation, the clipped action fed
back as ``last_action`` and the joint targets are formed exactly as in training
(arXiv 2603.08619, Sec. III: the action is a joint-position offset about q*).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hybrid_recovery.observation import actor_observation
from hybrid_recovery.robot.action import clip_action, joint_targets


@dataclass(frozen=True)
class PolicyStep:
    """What one policy step produced.

    Attributes:
        obs: The actor observation o_t, shape (87,), float32.
        action: The raw network output a_t, shape (27,).
        last_action: clip(a_t, ±ACTION_CLIP), the next step's a_{t−1}, shape (27,).
        q_ref: The joint targets q* + s · clip(a_t), clamped to the bounds when given,
            shape (27,) [rad], motor order.
    """

    obs: np.ndarray
    action: np.ndarray
    last_action: np.ndarray
    q_ref: np.ndarray


def policy_step(policy: Callable[[np.ndarray], np.ndarray], gyro: np.ndarray,
                quat: np.ndarray, q: np.ndarray, dq: np.ndarray, last_action: np.ndarray,
                scale: float,
                bounds: tuple[np.ndarray, np.ndarray] | None = None) -> PolicyStep:
    """o_t = actor_observation(ω, q_IMU, q, q̇, a_{t−1}); a_t = π(o_t); q_ref from a_t.

    Args:
        policy: Maps o_t (87,) to a_t (27,), e.g. an :class:`OnnxPolicy`.
        gyro: Torso IMU angular velocity ω, shape (3,) [rad/s], IMU frame.
        quat: Torso IMU orientation (w, x, y, z), shape (4,).
        q: Joint positions, shape (27,) [rad], motor order.
        dq: Joint velocities q̇, shape (27,) [rad/s].
        last_action: a_{t−1}, clipped, shape (27,).
        scale: s, the action scale [rad].
        bounds: (lower, upper) joint-target bounds [rad], or None for no clamp.

    Returns:
        The step's observation, raw and clipped action, and joint targets.
    """
    obs = actor_observation(gyro[None], quat[None], q[None], dq[None], last_action[None])[0]
    action = policy(obs)
    return PolicyStep(obs=obs, action=action, last_action=clip_action(action),
                      q_ref=joint_targets(action, scale, bounds))
