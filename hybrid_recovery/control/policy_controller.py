"""The learned policy as a torque controller: 50 Hz actions, PD law every physics step.

Every ``policy_dt`` :func:`hybrid_recovery.policy.policy_step` forms the observation o_t
(the shared builder, on :func:`read_proprioception`), runs the policy and the joint
targets q_ref = q* + 0.3 clip(a_t, ±10), clamped to the joint ranges scaled about their
middle by the policy's ``target_range_factor`` (as in training and on the robot); every
physics step τ = clip(K_P (q_ref − q) − K_D q̇, ±τ_max) with ``constants.KP``/``KD`` —
the law of the position servos of :func:`hybrid_recovery.robot.mjcf.load_mjmodel`,
written out so that the policy runs on the torque model shared with the QP controller.
New targets reach the PD law ``delay`` seconds after the observation they answer (the
actuation latency the policy was trained with, §III-D; the evaluation's ``learned``
controller uses the same 20 ms).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

import mujoco
import numpy as np

from hybrid_recovery.observation.mujoco_source import ProprioceptionMap, read_proprioception
from hybrid_recovery.policy.step import policy_step
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.action import TARGET_RANGE_FACTOR
from hybrid_recovery.robot.limits import SafetyLimits


def pd_torque(q_ref: np.ndarray, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """τ = clip(K_P (q_ref − q) − K_D q̇, ±τ_max), shape (27,) [N·m]."""
    tau = constants.KP * (q_ref - q) - constants.KD * qd
    return np.clip(tau, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)


class PolicyController:
    """A policy a = π(o) on the torque model.

    Args:
        policy: Maps o_t (87,) to a_t (27,), e.g. an
            :class:`hybrid_recovery.policy.OnnxPolicy`.
        policy_dt: Action period [s] (50 Hz).
        action_scale: q_ref = q* + scale · a [rad].
        delay: Actuation delay of the targets [s].

    Attributes:
        q_ref: The current joint targets, shape (27,) [rad].
        last_action: a_{t−1} (clipped), shape (27,).
    """

    def __init__(self, policy: Callable[[np.ndarray], np.ndarray], policy_dt: float = 0.02,
                 action_scale: float = 0.3, delay: float = 0.0) -> None:
        if policy_dt <= 0.0:
            raise ValueError("policy_dt must be > 0")
        if delay < 0.0:
            raise ValueError("delay must be >= 0")
        self.policy, self.policy_dt, self.action_scale = policy, policy_dt, action_scale
        self.delay = delay
        self._pending: deque[tuple[float, np.ndarray]] = deque()
        self.target_range_factor = float(getattr(policy, "target_range_factor",
                                                 TARGET_RANGE_FACTOR))
        self._bounds: tuple[np.ndarray, np.ndarray] | None = None
        self.q_ref = constants.DEFAULT_JOINT_POS.copy()
        self.last_action = np.zeros(constants.NUM_JOINTS)
        self._next_time = -np.inf
        self._where: ProprioceptionMap | None = None

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Zero last action; the first action is taken at the next call. Until a delayed
        target arrives, q_ref is the measured joint position (zero position error)."""
        self._where = ProprioceptionMap.of(model)
        self._bounds = SafetyLimits.from_model(model).q_ref_bounds(self.target_range_factor)
        self.last_action = np.zeros(constants.NUM_JOINTS)
        self.q_ref = (constants.DEFAULT_JOINT_POS.copy() if self.delay <= 0.0
                      else data.qpos[self._where.qadr].copy())
        self._next_time = -np.inf
        self._pending.clear()

    def joints(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(q, q̇) in motor order."""
        assert self._where is not None, "reset() first"
        return data.qpos[self._where.qadr], data.qvel[self._where.dadr]

    def update_targets(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Runs the policy when its period is due; returns q_ref (27,) [rad]."""
        if self._where is None:
            self.reset(model, data)
            assert self._where is not None
        if data.time >= self._next_time - 1e-9:
            step = policy_step(self.policy, *read_proprioception(model, data, self._where),
                               self.last_action, self.action_scale, self._bounds)
            self._pending.append((data.time + self.delay, step.q_ref))
            self.last_action = step.last_action
            self._next_time = data.time + self.policy_dt
        while self._pending and self._pending[0][0] <= data.time + 1e-9:
            self.q_ref = self._pending.popleft()[1]
        return self.q_ref

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """τ (27,) [N·m] from the PD law on the current targets."""
        q_ref = self.update_targets(model, data)
        q, qd = self.joints(data)
        return pd_torque(q_ref, q, qd)
