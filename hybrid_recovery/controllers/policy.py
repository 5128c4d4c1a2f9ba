"""The ``onnx:PATH`` and ``learned`` controllers: an exported policy on the PD servos."""

from __future__ import annotations

from collections import deque
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.controllers.protocol import OutputKind
from hybrid_recovery.observation.mujoco_source import ProprioceptionMap, read_proprioception
from hybrid_recovery.policy import OnnxPolicy, policy_step
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits


class OnnxPolicyController:
    """An exported policy at 50 Hz: shared observation builder, targets q* + s·clip(a)
    clamped as in training and on the robot, delay (``onnx:PATH``, ``learned``).

    Contract: position output (q_ref, held between policy steps) at 5 ms physics.

    Training clamps the targets to the joint ranges scaled about their middle by the
    curriculum's final position-limit factor, and the robot's safety layer does the same
    (``SafetyConfig.q_ref_range_factor``); so does this controller, by the policy's
    ``target_range_factor``. Without the clamp, a policy that drives joints against the
    training bound (a standing policy can hold its knees there in over 90 % of steps)
    meets a different robot here.

    Args:
        path: ``policy.onnx`` or the directory holding it and ``policy.json``.
        delay: actuation delay applied to the targets [s] (training sampled 10–40 ms).
    """

    output: OutputKind = "position"
    joint_target: np.ndarray | None = None
    physics_dt = 0.005

    def __init__(self, path: str | Path, delay: float = 0.02) -> None:
        self.policy = OnnxPolicy(path, require_description=True)
        assert self.policy.description is not None and self.policy.action_scale is not None
        self.scale = self.policy.action_scale
        self.period = float(self.policy.description["control_period_s"])
        self.delay = delay
        self.name = f"onnx:{self.policy.path}"

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        self.where = ProprioceptionMap.of(model)
        self.bounds = SafetyLimits.from_model(model).q_ref_bounds(
            self.policy.target_range_factor)
        self.decimation = max(1, int(round(self.period / model.opt.timestep)))
        self.delay_steps = int(round(self.delay / model.opt.timestep))
        self.step = 0
        self.last_action = np.zeros(constants.NUM_JOINTS)
        start = data.qpos[self.where.qadr].copy()
        self.pending: deque[tuple[int, np.ndarray]] = deque([(-1, start)])
        self.target = start

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        if self.step % self.decimation == 0:
            step = policy_step(self.policy, *read_proprioception(model, data, self.where),
                               self.last_action, self.scale, self.bounds)
            self.last_action = step.last_action
            self.pending.append((self.step + self.delay_steps, step.q_ref))
        while self.pending and self.pending[0][0] <= self.step:
            self.target = self.pending.popleft()[1]
        self.step += 1
        return self.target

    def info(self) -> dict:
        return {}
