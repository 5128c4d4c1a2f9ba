"""Controllers under evaluation: ``zero``, ``onnx:PATH``, ``qp``, ``model``, ``hybrid:PATH``.

A controller is called once per physics step with the MuJoCo model and data and returns
the actuator controls (position targets [rad] for position actuators, or torques [N·m]
for a torque-controlled model). ``physics_dt`` and ``torque_control`` tell the trial
runner which model to build.
"""

from __future__ import annotations

from collections import deque
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.observation.mujoco_source import ProprioceptionMap, read_proprioception
from hybrid_recovery.policy import SHIPPED, OnnxPolicy, policy_step, resolve_policy
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits


class ZeroController:
    """Zero actions: PD targets at the default pose (the policy's action origin)."""

    name = "zero"
    physics_dt = 0.005
    torque_control = False

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        del model, data

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        return constants.DEFAULT_JOINT_POS

    def info(self) -> dict:
        return {}


class OnnxPolicyController:
    """An exported policy at 50 Hz: shared observation builder, targets q* + s·clip(a)
    clamped as in training and on the robot, delay.

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

    torque_control = False
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


def policy_path(spec: str) -> Path | None:
    """The ``policy.onnx`` a controller spec runs (``learned``, ``onnx:PATH``,
    ``hybrid[:PATH]``), None for a controller without a policy or a path that does not
    exist."""
    kind, _, arg = spec.partition(":")
    if kind == "learned" or (kind == "hybrid" and not arg):
        arg = SHIPPED
    if kind not in ("learned", "onnx", "hybrid") or not arg:
        return None
    try:
        path = resolve_policy(arg)
    except FileNotFoundError:
        return None
    return path / "policy.onnx" if path.is_dir() else path


def make_controller(spec: str):
    """Builds a controller from ``zero``, ``learned``, ``onnx:PATH``, ``qp``, ``model`` or
    ``hybrid[:PATH]``.

    ``learned`` is the shipped policy (``onnx:shipped``); ``qp`` the QP balance controller
    alone; ``model`` the model-based half (the QP when up; when down, ground moves to
    knee-chest, the push-up to hands and knees, held there); ``hybrid`` the policy (the
    shipped one without a path) under the capturability supervisor with the QP, and ground
    moves to knee-chest where the policy lies still on the ground.

    Raises:
        ValueError: an unknown spec, a missing path, or ``learned`` with no shipped policy.
    """
    kind, _, arg = spec.partition(":")
    if kind == "zero":
        return ZeroController()
    if kind == "learned":
        kind, arg = "onnx", SHIPPED
    if kind == "hybrid" and not arg:
        arg = SHIPPED
    if kind == "onnx" and not arg:
        raise ValueError("onnx controller needs a path: onnx:PATH")
    if kind in ("onnx", "hybrid") and arg:
        try:
            arg = str(resolve_policy(arg))
        except FileNotFoundError as err:
            raise ValueError(str(err)) from err
    if kind == "onnx":
        return OnnxPolicyController(arg)
    if kind == "model":
        from hybrid_recovery.getup.controllers import ModelController

        return ModelController()
    if kind == "hybrid":
        from hybrid_recovery.evaluation.getup_controllers import GroundHybridController

        return GroundHybridController(arg)
    if kind == "qp":
        try:
            from hybrid_recovery.evaluation.model_controllers import eval_controller
        except ImportError as err:
            raise ValueError(f"controller '{kind}' is not available: {err}") from err
        return eval_controller(kind, arg or None)
    raise ValueError(f"unknown controller '{spec}': use zero, learned, onnx:PATH, qp, model "
                     "or hybrid[:PATH]")
