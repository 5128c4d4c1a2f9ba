"""The ONNX policy at 50 Hz: the training observation in, joint targets out.

The observation is built by :func:`hybrid_recovery.observation.actor_observation`, the
one builder the environment uses too: torso IMU angular velocity and orientation as
``LowState_.imu_state`` gives them, q − q*, q̇ and the last action. The network runs in
:class:`hybrid_recovery.policy.OnnxPolicy`; as in
:class:`~hybrid_recovery.envs.RecoveryEnv`, the action is clipped to ±``ACTION_CLIP``, the
clipped action is the next observation's ``last_action``, and the joint targets are
q_ref = q* + scale · a (:func:`hybrid_recovery.policy.policy_step`, ``policy.json``'s
action scale). The PD law τ = kp (q_ref − q) − kd q̇ runs in the motor drivers (or
MuJoCo's position actuators). No torch is imported.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hybrid_recovery.deploy.robot_io import JointCommand, LowStateReading
from hybrid_recovery.deploy.state_machine import Phase, PolicyOutput
from hybrid_recovery.policy import OnnxPolicy, policy_step
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.action import ACTION_CLIP, TARGET_RANGE_FACTOR

__all__ = ["ACTION_CLIP", "PolicyMismatchError", "PolicyRunner"]


class PolicyMismatchError(ValueError):
    """The policy does not fit this robot or this runner; the message says why."""


class PolicyRunner:
    """Runs ``policy.onnx`` with onnxruntime after checking ``policy.json``; its output
    is position targets (``output = "position"``).

    Args:
        policy_dir: Directory with ``policy.onnx`` and ``policy.json`` (from ``export``).
        period_s: This runner's control period [s]; must equal the policy's.
        threads: onnxruntime intra-op threads (1 keeps the loop's timing predictable).
        target_range_factor: the factor of the joint ranges the safety layer clamps the
            targets to (``SafetyConfig.q_ref_range_factor``); must equal the policy's.

    Raises:
        FileNotFoundError: ``policy.json`` or ``policy.onnx`` is missing.
        PolicyMismatchError: the description or the network does not match the robot
            constants, the observation layout or the control period.
    """

    output = "position"

    def __init__(self, policy_dir: str | Path, period_s: float = 0.02, threads: int = 1,
                 target_range_factor: float = TARGET_RANGE_FACTOR) -> None:
        self.policy_dir = policy_dir = Path(policy_dir)
        self.period_s = period_s
        try:
            self.policy = OnnxPolicy(policy_dir / "policy.onnx", threads,
                                     require_description=True)
        except ValueError as err:
            raise PolicyMismatchError(f"refusing policy {policy_dir}: {err}") from err
        desc = self.policy.description
        assert desc is not None and self.policy.action_scale is not None  # required above
        self._refuse_unless(np.allclose(desc["effort_limits"], constants.EFFORT_LIMITS),
                            "effort_limits differ from the robot constants")
        self._refuse_unless(abs(desc["control_period_s"] - period_s) < 1e-9,
                            f"it was trained at a control period of {desc['control_period_s']} "
                            f"s, this runner runs at {period_s} s")
        self._refuse_unless(abs(self.policy.target_range_factor - target_range_factor) < 1e-9,
                            f"its targets were clamped to the joint ranges × "
                            f"{self.policy.target_range_factor} in training, the safety layer "
                            f"clamps them to × {target_range_factor}")
        self.description = desc
        self.action_scale = self.policy.action_scale
        self.last_action = np.zeros(constants.NUM_JOINTS)

    def _refuse_unless(self, ok: bool, why: str) -> None:
        if not ok:
            raise PolicyMismatchError(f"refusing policy {self.policy_dir}: {why}")

    def reset(self) -> None:
        """Start of an episode: a_{t−1} = 0."""
        self.last_action = np.zeros(constants.NUM_JOINTS)

    def step(self, state: LowStateReading) -> PolicyOutput:
        """One control step: o_t, a_t, and q_ref = q* + scale · clip(a_t); remembers a_t."""
        step = policy_step(self.policy, state.gyro, state.quat, state.q, state.dq,
                           self.last_action, self.action_scale)
        self.last_action = step.last_action
        return PolicyOutput(obs=step.obs, action=step.action, q_ref=step.q_ref)

    def command(self, cmd: JointCommand, phase: Phase) -> JointCommand:
        """The machine's command as sent: the policy's targets with its gains, unchanged."""
        del phase
        return cmd
