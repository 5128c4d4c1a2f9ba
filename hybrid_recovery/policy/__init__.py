"""The exported policy, below every runner: ``policy.json``, action → targets, onnxruntime.

Control, evaluation, ``play`` and deploy all load and run a policy through
:class:`OnnxPolicy` and form joint targets with :func:`joint_targets`, the environment
too. Nothing here imports torch (onnxruntime is imported when a policy is loaded).
"""

from hybrid_recovery.policy.action import (
    ACTION_CLIP,
    TARGET_RANGE_FACTOR,
    clip_action,
    joint_targets,
)
from hybrid_recovery.policy.description import (
    POLICY_FORMAT,
    check_meta,
    load_policy_description,
)
from hybrid_recovery.policy.onnx_policy import OnnxPolicy
from hybrid_recovery.policy.shipped import SHIPPED, SHIPPED_POLICY, is_shipped, resolve_policy

__all__ = [
    "ACTION_CLIP",
    "POLICY_FORMAT",
    "OnnxPolicy",
    "SHIPPED",
    "SHIPPED_POLICY",
    "TARGET_RANGE_FACTOR",
    "check_meta",
    "clip_action",
    "is_shipped",
    "joint_targets",
    "load_policy_description",
    "resolve_policy",
]
