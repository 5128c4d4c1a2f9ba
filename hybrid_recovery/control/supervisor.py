"""Hybrid supervisor: the QP for ankle and hip strategies, the policy for everything else.

State machine (every physics step; decisions appended to :attr:`HybridSupervisor.events`):

* **qp → policy** when the QP does not apply (robot down: low CoM, non-foot contact,
  large tilt), or when the QP's capturability analysis says that its ankle and hip
  strategies no longer capture ξ (:attr:`SupervisorConfig.hand_over_at`: a step is
  needed, or nothing captures) for ``to_policy_delay`` (0: at once). The QP never steps
  in the hybrid (:meth:`HybridSupervisor.from_onnx` disables its stepping): a step, a
  brace or a fall is the policy's, which was trained for the whole cycle, and it gets
  the robot while the push is still being absorbed rather than after a failed step.
  The policy runs in the background in both modes (its observation history, previous
  action and delayed targets stay current), so it acts at once on a hand-over. Hand-over
  of joint targets: q_ref = (1 − α) q_switch + α (q* + 0.3 a_t), α ramping 0 → 1 over
  ``to_policy_blend`` from the measured joints q_switch, so the PD law starts from zero
  position error instead of jumping to the policy's targets.
* The policy acts first: it brings the robot into its own stance (or up from the
  ground), which the QP then holds.
* **policy → qp** once the robot has stood for ``to_qp_dwell`` without a break: the QP
  applies, ξ is at least ``to_qp_margin`` inside the feet polygon, the CoM is above
  ``to_qp_min_com_height`` and slower than ``to_qp_max_com_speed``. The QP restarts from
  the policy's stance: ξ_ref and the CoM height from the current CoM, and the posture
  task holds the joints as the policy left them (the feet may be apart after steps).
  Hand-over of torques: τ = (1 − α) τ_policy + α τ_QP over ``to_qp_blend``.

**Model validity** (:mod:`hybrid_recovery.control.model_validity`): the hand-over to the QP
also needs its model to hold, else the hybrid acts as the policy alone. At the end of the
dwell the ground tilt θ ≤ ``max_ground_tilt`` (gravity along the contact normal) and the
weight ratio ρ averaged over the dwell within ``max_weight_error`` of 1 (the model's
mass); a blocked hand-over is logged once per reason (``qp_blocked``) and the dwell starts
again. In either mode, a torque error e > ``max_torque_error`` (the motors did not apply
the command) marks the QP's torque model wrong for the episode: the policy acts from then
on (``to_policy``, or ``qp_blocked`` while it already does).

The entry conditions of the QP are stricter than its exit conditions (0-step capturable
with margin, slow, for a dwell time, against "the hip strategy no longer suffices"):
that gap and the dwell time are the hysteresis.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.applicability import check_state
from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.config import BalanceConfig, SupervisorConfig, default_config
from hybrid_recovery.control.diagnostics import Capturability, Event, TickDiagnostics
from hybrid_recovery.control.model_validity import (
    foot_body_ids,
    ground_tilt,
    torque_error,
    weight_ratio,
)
from hybrid_recovery.control.policy_controller import PolicyController, pd_torque
from hybrid_recovery.policy import OnnxPolicy

QP, POLICY = "qp", "policy"


def ankle_and_hip_only(config: BalanceConfig | None = None) -> BalanceConfig:
    """``config`` (default: the tuned one) with the QP's stepping disabled."""
    config = config or default_config()
    return dataclasses.replace(config,
                               stepping=dataclasses.replace(config.stepping, enabled=False))


class HybridSupervisor:
    """Switches between a :class:`BalanceController` and a learned :class:`PolicyController`.

    Args:
        balance: The QP balance controller.
        policy: The learned policy on the torque model.
        config: Switching thresholds; defaults when None.

    Attributes:
        mode: ``"qp"`` or ``"policy"``.
        events: Switching decisions (``"to_policy"``, ``"to_qp"``, ``"qp_blocked"``) with
            their reasons.
        mismatch: Why the QP's torque model is wrong this episode (the motors missed a
            command by more than ``max_torque_error``); None until then.
        diagnostics: The last tick's :class:`TickDiagnostics` of the capturability check.
        ground_sensed: The state's contact forces are measured (simulation); False where
            they are only the model's (the robot runner's estimate: the H1-2 has no foot
            force sensors), which skips the weight check.
        joint_target: When the last output was the policy's PD law alone, its joint
            targets q_ref (27,) [rad] (for PD servos: the same torque without the
            round trip through τ, exact also where τ is clipped); None otherwise.
    """

    def __init__(self, balance: BalanceController, policy: PolicyController,
                 config: SupervisorConfig | None = None) -> None:
        self.balance, self.policy = balance, policy
        self.config = config or SupervisorConfig()
        self.mode = QP
        self.events: list[Event] = []
        self.diagnostics: TickDiagnostics | None = None
        self.joint_target: np.ndarray | None = None
        self.ground_sensed = True
        self._timer = 0.0
        self._switch_time = -np.inf
        self._q_switch = np.zeros(0)
        self.mismatch: str | None = None
        self._command: np.ndarray | None = None
        self._weight_sum, self._weight_count = 0.0, 0
        self._blocked: set[str] = set()

    @classmethod
    def from_onnx(cls, path: str | Path, balance_config: BalanceConfig | None = None,
                  config: SupervisorConfig | None = None) -> HybridSupervisor:
        """The QP controller (ankle and hip strategies, :func:`ankle_and_hip_only`) plus an
        exported policy (``.onnx``) at 50 Hz."""
        cfg = config or SupervisorConfig()
        policy = PolicyController(OnnxPolicy(path), cfg.policy_dt, cfg.action_scale,
                                  cfg.policy_delay)
        return cls(BalanceController(ankle_and_hip_only(balance_config)), policy, cfg)

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Starts with the policy: it stands the robot up in its own stance, which the QP
        then holds (policy → qp after ``to_qp_dwell``)."""
        self.balance.reset(model, data)
        self.policy.reset(model, data)
        self._timer = 0.0
        self._switch_time = -np.inf
        self.mismatch, self._command = None, None
        self._weight_sum, self._weight_count = 0.0, 0
        self._blocked = set()
        first = self.balance.assess(model, data)
        self.diagnostics = first
        self.mode = POLICY
        self._q_switch = self.policy.joints(data)[0].copy()
        why = "QP applicable" if first.applicable else f"QP not applicable ({first.reason})"
        self.events = [Event(float(data.time), "to_policy", f"start: the policy stands first "
                             f"({why})")]

    def _alpha(self, t: float, blend: float) -> float:
        return 1.0 if blend <= 0.0 else float(np.clip((t - self._switch_time) / blend, 0.0, 1.0))

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m] of the active controller, blended during a hand-over.

        ``data.actuator_force`` is read as the torque the motors applied in the last step,
        to check the command of the call before (:attr:`mismatch`).

        Raises:
            ValueError: On a non-finite state (as :class:`BalanceController`).
        """
        self._command = self._tick(model, data)
        return self._command

    def _check_torque(self, data: mujoco.MjData) -> None:
        """Latches :attr:`mismatch` once the applied torque is off the last command; a
        state without a torque reading (``data.actuator_force`` not finite, as the robot
        runner's estimate) is not checked."""
        if (self.mismatch is not None or self._command is None
                or not np.all(np.isfinite(data.actuator_force))):
            return
        command = self._command
        error = torque_error(data.actuator_force, command)
        if error > self.config.max_torque_error:
            self.mismatch = (f"torque model mismatch: applied torque off the command by "
                             f"{error:.0%} of the limit")

    def _valid(self, model: mujoco.MjModel, data: mujoco.MjData) -> str | None:
        """Why the QP's model does not hold now (None: it does), at the end of the dwell."""
        cfg = self.config
        tilt = ground_tilt(model, data, foot_body_ids(model))
        ratio = self._weight_sum / max(self._weight_count, 1)
        if self.mismatch is not None:
            return self.mismatch
        if tilt > cfg.max_ground_tilt:
            return f"ground tilted {np.degrees(tilt):.1f} deg from the vertical"
        if self.ground_sensed and abs(ratio - 1.0) > cfg.max_weight_error:
            return f"ground reaction {ratio:.2f} times the model's weight"
        return None

    def _block(self, t: float, reason: str) -> None:
        """Logs a blocked hand-over to the QP, once per kind of reason."""
        kind = " ".join(reason.split()[:2])
        if kind not in self._blocked:
            self._blocked.add(kind)
            self.events.append(Event(t, "qp_blocked", reason))

    def _tick(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        check_state(data)
        self._check_torque(data)
        t, dt = float(data.time), float(model.opt.timestep)
        cfg = self.config
        self.joint_target = None
        q_ref = self.policy.update_targets(model, data)  # warm in either mode
        if self.mode == QP:
            torque = self.balance(model, data)
            diag = self.diagnostics = self.balance.diagnostics
            assert diag is not None
            if not diag.applicable:
                return self._to_policy(model, data, f"QP not applicable: {diag.reason}")
            if self.mismatch is not None:
                self._blocked.add("torque model")  # the hand-over says why
                return self._to_policy(model, data, self.mismatch)
            beyond = diag.capturability >= cfg.hand_over_at
            self._timer = self._timer + dt if beyond else 0.0
            if beyond and self._timer >= cfg.to_policy_delay - 1e-9:
                return self._to_policy(model, data, "not capturable by the ankle or hip "
                                       f"strategy ({diag.capturability.name.lower()})")
            alpha = self._alpha(t, cfg.to_qp_blend)
            if alpha < 1.0:  # policy → QP hand-over still blending
                q, qd = self.policy.joints(data)
                torque = (1.0 - alpha) * pd_torque(q_ref, q, qd) + alpha * torque
            return torque
        diag = self.diagnostics = self.balance.assess(model, data)
        standing = (diag.applicable and diag.capturability == Capturability.ZERO_STEP
                    and diag.margin >= cfg.to_qp_margin
                    and diag.com[2] >= cfg.to_qp_min_com_height
                    and float(np.linalg.norm(diag.com_vel)) <= cfg.to_qp_max_com_speed)
        self._timer = self._timer + dt if standing else 0.0
        if standing:
            self._weight_sum += weight_ratio(model, data, mujoco.mj_getTotalmass(model))
            self._weight_count += 1
        else:
            self._weight_sum, self._weight_count = 0.0, 0
        if self.mismatch is not None:
            self._block(t, self.mismatch)
        q, qd = self.policy.joints(data)
        alpha = self._alpha(t, cfg.to_policy_blend)
        target = (1.0 - alpha) * self._q_switch + alpha * q_ref
        policy_torque = pd_torque(target, q, qd)
        invalid = self._valid(model, data) if self._timer >= cfg.to_qp_dwell - 1e-9 else None
        if invalid is not None:
            self._timer, self._weight_sum, self._weight_count = 0.0, 0.0, 0
            self._block(t, invalid)
        elif self._timer >= cfg.to_qp_dwell - 1e-9:
            self.mode, self._timer, self._switch_time = QP, 0.0, t
            self.events.append(Event(t, "to_qp", f"standing for {cfg.to_qp_dwell:.2f} s "
                                     f"(margin {diag.margin:.3f} m)"))
            self.balance.reset(model, data, posture=q.copy())
            torque = self.balance(model, data)
            alpha = self._alpha(t, cfg.to_qp_blend)
            return policy_torque * (1.0 - alpha) + alpha * torque
        self.joint_target = target
        return policy_torque

    def _to_policy(self, model: mujoco.MjModel, data: mujoco.MjData, reason: str) -> np.ndarray:
        t = float(data.time)
        self.mode, self._timer, self._switch_time = POLICY, 0.0, t
        self.events.append(Event(t, "to_policy", reason))
        self._q_switch = self.policy.joints(data)[0].copy()
        q_ref = self.policy.update_targets(model, data)
        q, qd = self.policy.joints(data)
        alpha = self._alpha(t, self.config.to_policy_blend)
        self.joint_target = (1.0 - alpha) * self._q_switch + alpha * q_ref
        return pd_torque(self.joint_target, q, qd)
