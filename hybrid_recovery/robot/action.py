"""Action → joint targets, as in training: q_ref = q* + s · clip(a, ±ACTION_CLIP).

The environment and :func:`hybrid_recovery.policy.policy_step` (the deploy runner and the
MuJoCo controllers) go through :func:`joint_targets`, so the robot gets the targets the
policy was trained on; the clipped action (:func:`clip_action`) is the next
observation's ``last_action``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from array_api_compat import array_namespace, device, is_array_api_obj

from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS

if TYPE_CHECKING:
    import torch
    from numpy.typing import ArrayLike

ACTION_CLIP = 10.0
"""|a| bound applied to the policy output before the targets are formed."""
TARGET_RANGE_FACTOR = 0.9
"""Targets are clamped to the joint ranges scaled about their middle by this factor: at
the end of training's curriculum (``CurriculumConfig.position_limit_final``), on the robot
(``SafetyConfig.q_ref_range_factor``) and by the evaluation's policy controllers."""


def clip_action(action: ArrayLike | torch.Tensor) -> Any:
    """clip(a, −ACTION_CLIP, ACTION_CLIP), shape (..., 27): float64 numpy for numpy arrays
    and lists, a tensor of the same dtype and device for torch tensors."""
    if not is_array_api_obj(action) or isinstance(action, np.ndarray):
        return np.clip(np.asarray(action, dtype=float), -ACTION_CLIP, ACTION_CLIP)
    return array_namespace(action).clip(action, -ACTION_CLIP, ACTION_CLIP)


def joint_targets(action: ArrayLike | torch.Tensor, scale: float,
                  bounds: tuple[Any, Any] | None = None) -> Any:
    """q_ref = q* + s · clip(a, ±ACTION_CLIP), clamped to ``bounds`` where given.

    Args:
        action: a_t (unscaled policy output), shape (..., 27): numpy (or a list) or a
            torch tensor (then q_ref is one, on its device).
        scale: s, the action scale [rad] (``policy.json``'s ``action.scale``, 0.3).
        bounds: (lower, upper) joint targets [rad], broadcast against q_ref: the joint
            ranges scaled by :data:`TARGET_RANGE_FACTOR` (or training's current factor).

    Returns:
        q_ref, shape (..., 27) [rad], motor order.
    """
    a = clip_action(action)
    xp = array_namespace(a)
    q_ref = xp.asarray(DEFAULT_JOINT_POS, copy=True, device=device(a)) + scale * a
    return q_ref if bounds is None else xp.clip(q_ref, *bounds)
