"""Action → joint targets, as in training: q_ref = q* + s · clip(a, ±ACTION_CLIP).

The environment and :func:`hybrid_recovery.policy.policy_step` (the deploy runner and the
MuJoCo controllers) go through :func:`joint_targets`, so the robot gets the targets the
policy was trained on; the clipped action (:func:`clip_action`) is the next
observation's ``last_action``.
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS

ACTION_CLIP = 10.0
"""|a| bound applied to the policy output before the targets are formed."""
TARGET_RANGE_FACTOR = 0.9
"""Targets are clamped to the joint ranges scaled about their middle by this factor: at
the end of training's curriculum (``CurriculumConfig.position_limit_final``), on the robot
(``SafetyConfig.q_ref_range_factor``) and by the evaluation's policy controllers."""


def clip_action(action: np.ndarray) -> np.ndarray:
    """clip(a, −ACTION_CLIP, ACTION_CLIP), shape (..., 27), float64."""
    return np.clip(np.asarray(action, dtype=float), -ACTION_CLIP, ACTION_CLIP)


def joint_targets(action: np.ndarray, scale: float,
                  bounds: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """q_ref = q* + s · clip(a, ±ACTION_CLIP), clamped to ``bounds`` where given.

    Args:
        action: a_t (unscaled policy output), shape (..., 27).
        scale: s, the action scale [rad] (``policy.json``'s ``action.scale``, 0.3).
        bounds: (lower, upper) joint targets [rad], broadcast against q_ref: the joint
            ranges scaled by :data:`TARGET_RANGE_FACTOR` (or training's current factor).

    Returns:
        q_ref, shape (..., 27) [rad], motor order.
    """
    q_ref = DEFAULT_JOINT_POS + scale * clip_action(action)
    return q_ref if bounds is None else np.clip(q_ref, *bounds)
