"""Any registered controller on the robot (:mod:`hybrid_recovery.controllers`).

An exported policy (``learned``, ``onnx:PATH``) runs in :class:`~.policy_runner.PolicyRunner`
on the ``LowState_`` itself. Every other controller runs in :class:`ControllerRunner` on
the :class:`~.state_estimate.StateEstimate` of its model, once per its ``physics_dt``, and
is asked for torques where it offers them. What goes out in the POLICY phase:

* ``"position"``: q_ref with the safety machine's gains, as for the policy;
* ``"torque"``: the low-level command's feed-forward torque τ clipped to ±τ_max, with
  kp = kd = 0 (τ is the whole motor torque, as on the torque model the controller was
  designed on) and q = the measured q; but where the step's τ is the PD law on joint
  targets (``Controller.joint_target``: the hybrid while the policy or the moves act),
  those targets with the machine's gains, so the drivers run that PD law at their rate.

Every other phase is the machine's command.
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.control.torque_model import torque_twin
from hybrid_recovery.controllers import Controller, HybridController, OutputKind, make, policy_path
from hybrid_recovery.deploy.policy_runner import PolicyRunner
from hybrid_recovery.deploy.robot_io import JointCommand, LowStateReading
from hybrid_recovery.deploy.state_estimate import StateEstimate
from hybrid_recovery.deploy.state_machine import Phase, PolicyOutput
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.scene import build_scene

POLICY_SPECS = ("learned", "onnx")
"""Specs that run in :class:`PolicyRunner` (the policy reads the robot's state directly)."""


class ControllerRunner:
    """A registered controller on the estimated state of the robot.

    Args:
        controller: The controller (built with ``prefer="torque"``).
    """

    def __init__(self, controller: Controller) -> None:
        self.controller = controller
        self.output: OutputKind = controller.output
        self.period_s = controller.physics_dt
        model = build_scene(None, controller.physics_dt)[0]
        self.model = torque_twin(model) if self.output == "torque" else model
        self.estimate = StateEstimate(self.model)
        if isinstance(controller, HybridController):  # no measured ground reaction here
            controller.supervised.supervisor.ground_sensed = False
        self._fresh = True
        self._torque: np.ndarray | None = None

    def reset(self) -> None:
        """Start of the POLICY phase: the controller resets on the next state."""
        self._fresh = True
        self.estimate.reset()

    def step(self, state: LowStateReading) -> PolicyOutput:
        """One control step on the estimated state. The output's ``obs`` is the estimate
        (qpos, qvel), ``action`` the controller's command; ``q_ref`` its targets (the
        joint targets of a PD-law torque), or else the measured q for a torque controller
        (the machine clamps and checks it)."""
        data = self.estimate.update(state)
        if self._fresh:
            self.controller.reset(self.model, data)
            self._fresh = False
        command = np.asarray(self.controller(self.model, data), dtype=float).copy()
        obs = np.concatenate([data.qpos, data.qvel])
        target = self.controller.joint_target
        if self.output == "torque" and target is None:
            self._torque = command
            return PolicyOutput(obs=obs, action=command, q_ref=state.q.copy())
        q_ref = command if self.output == "position" else np.asarray(target, dtype=float)
        return PolicyOutput(obs=obs, action=command, q_ref=q_ref.copy())

    def command(self, cmd: JointCommand, phase: Phase) -> JointCommand:
        """The machine's command as sent: in POLICY after a torque step, τ clipped to
        ±τ_max with kp = kd = 0; otherwise ``cmd`` unchanged."""
        torque, self._torque = self._torque, None
        if self.output != "torque" or phase is not Phase.POLICY or torque is None:
            return cmd
        zero = np.zeros(constants.NUM_JOINTS)
        tau = np.clip(torque, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
        return JointCommand(q=cmd.q, kp=zero, kd=zero.copy(), tau=tau)


def make_runner(spec: str, target_range_factor: float) -> PolicyRunner | ControllerRunner:
    """The runner of a controller spec (:func:`hybrid_recovery.controllers.make`).

    Args:
        spec: ``NAME`` or ``NAME:PATH``; ``onnx:DIR`` for an export directory.
        target_range_factor: The safety layer's target clamp, checked against a policy's.

    Raises:
        ValueError: an unknown spec (the message lists the known names), a missing
            policy, or :class:`~.policy_runner.PolicyMismatchError`.
    """
    if spec.partition(":")[0] in POLICY_SPECS:
        path = policy_path(spec)
        if path is None:
            make(spec)  # raises the registry's message
        assert path is not None
        return PolicyRunner(path.parent, target_range_factor=target_range_factor)
    return ControllerRunner(make(spec, prefer="torque"))
