"""The exported policy, below every runner: ``policy.json``, onnxruntime, the policy step.

Control, evaluation, ``play`` and deploy all load and run a policy through
:class:`OnnxPolicy` and step it with :func:`policy_step` (observation → policy → clip →
targets, the action mapping of :mod:`hybrid_recovery.robot.action`). Nothing here imports
torch (onnxruntime is imported when a policy is loaded).
"""

from hybrid_recovery.policy.description import (
    POLICY_FORMAT,
    check_meta,
    load_policy_description,
)
from hybrid_recovery.policy.onnx_policy import OnnxPolicy
from hybrid_recovery.policy.shipped import SHIPPED, SHIPPED_POLICY, is_shipped, resolve_policy
from hybrid_recovery.policy.step import PolicyStep, policy_step

__all__ = [
    "POLICY_FORMAT",
    "OnnxPolicy",
    "PolicyStep",
    "SHIPPED",
    "SHIPPED_POLICY",
    "check_meta",
    "is_shipped",
    "load_policy_description",
    "policy_step",
    "resolve_policy",
]
