"""The deployment safety state machine: pure logic, no I/O, no clock of its own.

Phases, in order::

    WAIT_STATE ─first valid state─▶ ZERO_TORQUE ─zero_torque_s─▶ INTERPOLATE ─interpolate_s─▶
    HOLD ─hold_s (+ start)─▶ POLICY            any phase ─fault or stop─▶ DAMPING (final)

* WAIT_STATE: nothing is sent until a state with a valid CRC arrives.
* ZERO_TORQUE: motors enabled with kp = kd = 0, tau = 0 (limp).
* INTERPOLATE: q_ref = q₀ + α (q* − q₀), α = t / interpolate_s, from the pose q₀ measured
  when the phase began to the default pose q*, with the constants' gains.
* HOLD: q_ref = q*; after hold_s the policy starts (at once with ``auto_start_policy``,
  otherwise on :meth:`SafetyStateMachine.start_policy`).
* POLICY: q_ref from the policy, clamped to the joint ranges × ``q_ref_range_factor``.
* DAMPING: kp = 0, kd = ``damping_kd``; entered on :meth:`~SafetyStateMachine.request_stop`
  (exit) or on a fault, and never left.

Faults (checked every tick after WAIT_STATE): a non-finite state, observation or action; an
IMU quaternion whose norm is not 1 ± ``quat_tolerance``; a measured joint position beyond
its range ± ``joint_margin``; a measured torque beyond τ_max (1 + ``torque_tolerance``); no
new state (newer tick, valid CRC) for ``stale_timeout_s``; a tick later than
``period_s + overrun_s`` after the previous one; an exception in the controller's loop
or another writer's commands on ``rt/lowcmd``, reported by the loop
(:meth:`SafetyStateMachine.fail_safe`).

A state is new when its tick is ahead of the last one's modulo 2³² (the robot's u32
counter wraps): an older or repeated tick is ignored.
Gains are clamped to [0, constants.KP] and [0, constants.KD] in every phase.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from hybrid_recovery.deploy.robot_io import JointCommand, LowStateReading
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.action import TARGET_RANGE_FACTOR
from hybrid_recovery.robot.limits import SafetyLimits

_EPS = 1e-6  # [s]: a phase of 0.5 s ends on the tick at 0.5 s despite float rounding
_TICK_MOD = 2**32
"""``LowState_.tick`` is a u32 counter that wraps."""


def tick_is_newer(tick: int, last: int) -> bool:
    """Whether ``tick`` is ahead of ``last`` modulo 2³² (by less than half the range)."""
    return 0 < (tick - last) % _TICK_MOD < _TICK_MOD // 2


class Phase(enum.Enum):
    """Phases of the deployment sequence."""

    WAIT_STATE = "wait_state"
    ZERO_TORQUE = "zero_torque"
    INTERPOLATE = "interpolate"
    HOLD = "hold"
    POLICY = "policy"
    DAMPING = "damping"


class Fault(enum.Enum):
    """Why the machine went to DAMPING (None when it was asked to stop)."""

    NONFINITE_STATE = "nonfinite_state"
    NONFINITE_OBSERVATION = "nonfinite_observation"
    NONFINITE_ACTION = "nonfinite_action"
    JOINT_LIMIT = "joint_limit"
    TORQUE_LIMIT = "torque_limit"
    STALE_STATE = "stale_state"
    OVERRUN = "overrun"
    IMU_QUATERNION = "imu_quaternion"
    CONTROLLER_ERROR = "controller_error"
    OTHER_WRITER = "other_writer"


@dataclass(frozen=True)
class PolicyOutput:
    """What the policy produced this tick.

    Attributes:
        obs: The observation o_t, shape (87,).
        action: The raw network output a_t, shape (27,).
        q_ref: The joint targets derived from it, shape (27,) [rad].
    """

    obs: np.ndarray
    action: np.ndarray
    q_ref: np.ndarray


@dataclass(frozen=True)
class SafetyConfig:
    """Timings [s] and thresholds of the state machine."""

    limits: SafetyLimits
    period_s: float = 0.02
    """Control period (50 Hz)."""
    zero_torque_s: float = 0.5
    interpolate_s: float = 2.0
    hold_s: float = 1.0
    auto_start_policy: bool = True
    """Start the policy after hold_s by itself; False waits for ``start_policy()``."""
    skip_startup: bool = False
    """Go from WAIT_STATE straight to POLICY (simulation of falls only, never hardware)."""
    stale_timeout_s: float = 0.1
    """No new state for this long is a fault (5 control periods; states come at 500 Hz)."""
    overrun_s: float = 0.02
    """A tick more than period_s + overrun_s after the previous one is a fault."""
    joint_margin: float = 0.1
    """Measured q may exceed the joint range by this much before it is a fault [rad]."""
    torque_tolerance: float = 0.1
    """Measured |τ| may exceed τ_max by this fraction before it is a fault."""
    quat_tolerance: float = 0.01
    """The IMU quaternion's norm may differ from 1 by this much before it is a fault
    (a float32 unit quaternion is within 1e-6; (2, 0, 0, 0) would scale the projected
    gravity the policy sees to a quarter)."""
    q_ref_range_factor: float = TARGET_RANGE_FACTOR
    """Targets are clamped to the joint ranges scaled about their middle by this (as at
    the end of training's curriculum, ``CurriculumConfig.position_limit_final``)."""
    kp: np.ndarray = field(default_factory=lambda: constants.KP)
    """Stiffness of INTERPOLATE, HOLD and POLICY [N·m/rad] (clamped to the constants')."""
    kd: np.ndarray = field(default_factory=lambda: constants.KD)
    """Damping of INTERPOLATE, HOLD and POLICY [N·m·s/rad] (clamped likewise)."""
    damping_kd: np.ndarray = field(default_factory=lambda: constants.KD)
    """Damping of the DAMPING phase [N·m·s/rad] (clamped likewise)."""


class SafetyStateMachine:
    """Turns (time, latest state, policy output) into the next motor command.

    Args:
        config: Timings, thresholds and limits.
    """

    def __init__(self, config: SafetyConfig) -> None:
        self.config = c = config
        self.phase = Phase.WAIT_STATE
        self.fault: Fault | None = None
        self.fault_detail = ""
        self.transitions: list[tuple[float, Phase, str]] = []
        """(time, new phase, reason) of every transition."""
        self._kp, self._kd = c.limits.clamp_gains(c.kp, c.kd)
        self._damping_kd = c.limits.clamp_gains(c.kp, c.damping_kd)[1]
        self._q_lo, self._q_hi = c.limits.q_ref_bounds(c.q_ref_range_factor)
        self._state: LowStateReading | None = None
        self._t_new_state = 0.0
        self._t_phase = 0.0
        self._last_tick: float | None = None
        self._q0 = c.limits.default_q
        self._last_q_ref = c.limits.default_q
        self._stop_reason: str | None = None
        self._start_requested = False

    # ------------------------------------------------------------------ operator input
    def request_stop(self, reason: str = "stop requested") -> None:
        """Go to DAMPING at the next tick (the normal exit)."""
        self._stop_reason = reason

    def start_policy(self) -> None:
        """Allow HOLD → POLICY (needed when ``auto_start_policy`` is False)."""
        self._start_requested = True

    @property
    def state(self) -> LowStateReading | None:
        """The newest valid state seen."""
        return self._state

    # ------------------------------------------------------------------ the tick
    def tick(self, now: float, state: LowStateReading | None,
             policy: PolicyOutput | None = None) -> JointCommand | None:
        """Advances the machine and returns the command to send (None: send nothing).

        Args:
            now: Current time [s], the clock of ``state.t_receive``.
            state: The newest received state (or None); states with a bad CRC or a tick
                not ahead of the last one (modulo 2³²) are ignored.
            policy: The policy's output for this tick; only used in POLICY. Evaluate the
                policy only when :attr:`phase` is POLICY before the call.
        """
        previous, self._last_tick = self._last_tick, now
        if state is not None and state.crc_ok and (
                self._state is None or tick_is_newer(state.tick, self._state.tick)):
            self._state, self._t_new_state = state, state.t_receive
        if self.phase is Phase.DAMPING:
            return self._damping()
        if self._stop_reason is not None:
            return self._fail(now, None, self._stop_reason)
        if self.phase is Phase.WAIT_STATE:
            if self._state is None:
                return None
            first = Phase.POLICY if self.config.skip_startup else Phase.ZERO_TORQUE
            self._enter(now, first, f"first state, tick {self._state.tick}")
        elif previous is not None and now - previous > self.config.period_s + self.config.overrun_s:
            return self._fail(now, Fault.OVERRUN,
                              f"tick {1e3 * (now - previous):.1f} ms after the previous one "
                              f"(period {1e3 * self.config.period_s:.0f} ms)")
        found = self._check_state(now)
        if found is not None:
            return self._fail(now, *found)
        self._advance(now)
        return self._command(now, policy)

    def fail_safe(self, now: float, detail: str,
                  fault: Fault = Fault.CONTROLLER_ERROR) -> JointCommand:
        """Goes to DAMPING at once with ``fault`` (found by the loop around the machine:
        :attr:`Fault.CONTROLLER_ERROR` when it failed, :attr:`Fault.OTHER_WRITER` when
        another process commands the robot too) and returns the damping command, without
        any check that could fail again."""
        if self.phase is Phase.DAMPING:
            return self._damping()
        return self._fail(now, fault, detail)

    # ------------------------------------------------------------------ internals
    def _enter(self, now: float, phase: Phase, reason: str) -> None:
        self.phase, self._t_phase = phase, now
        self.transitions.append((now, phase, reason))
        if phase is Phase.INTERPOLATE:
            assert self._state is not None
            self._q0 = np.clip(self._state.q, self._q_lo, self._q_hi)

    def _fail(self, now: float, fault: Fault | None, detail: str) -> JointCommand:
        self.fault, self.fault_detail = fault, detail
        self._enter(now, Phase.DAMPING, detail if fault is None else f"{fault.value}: {detail}")
        return self._damping()

    def _damping(self) -> JointCommand:
        q = self._state.q if self._state is not None else self.config.limits.default_q
        zero = np.zeros(constants.NUM_JOINTS)
        return JointCommand(q=np.nan_to_num(q).copy(), kp=zero, kd=self._damping_kd.copy())

    def _check_state(self, now: float) -> tuple[Fault, str] | None:
        c, s = self.config, self._state
        assert s is not None
        if now - self._t_new_state > c.stale_timeout_s:
            return Fault.STALE_STATE, (f"no new state for {1e3 * (now - self._t_new_state):.0f} "
                                       f"ms (last tick {s.tick})")
        if not s.is_finite():
            return Fault.NONFINITE_STATE, f"state at tick {s.tick} has NaN or inf"
        norm = float(np.linalg.norm(s.quat))
        if abs(norm - 1.0) > c.quat_tolerance:
            return Fault.IMU_QUATERNION, (f"IMU quaternion norm {norm:.3f} at tick {s.tick}, "
                                          f"expected 1 ± {c.quat_tolerance}")
        lim, m = c.limits, c.joint_margin
        out = np.flatnonzero((s.q < lim.q_min - m) | (s.q > lim.q_max + m))
        if len(out):
            i = int(out[0])
            return Fault.JOINT_LIMIT, (f"{constants.JOINT_NAMES[i]} at {s.q[i]:.3f} rad outside "
                                       f"[{lim.q_min[i]:.3f}, {lim.q_max[i]:.3f}] ± {m} rad")
        over = np.flatnonzero(np.abs(s.tau_est) > lim.effort * (1 + c.torque_tolerance))
        if len(over):
            i = int(over[0])
            return Fault.TORQUE_LIMIT, (f"{constants.JOINT_NAMES[i]} torque {s.tau_est[i]:.1f} "
                                        f"N·m beyond {lim.effort[i]:.0f} N·m "
                                        f"(+{100 * c.torque_tolerance:.0f} %)")
        return None

    def _advance(self, now: float) -> None:
        c, elapsed = self.config, now - self._t_phase + _EPS
        if self.phase is Phase.ZERO_TORQUE and elapsed >= c.zero_torque_s:
            self._enter(now, Phase.INTERPOLATE, f"{c.zero_torque_s} s of zero torque")
        elif self.phase is Phase.INTERPOLATE and elapsed >= c.interpolate_s:
            self._enter(now, Phase.HOLD, "default pose reached")
        elif (self.phase is Phase.HOLD and elapsed >= c.hold_s
              and (c.auto_start_policy or self._start_requested)):
            self._enter(now, Phase.POLICY, "policy started")

    def _command(self, now: float, policy: PolicyOutput | None) -> JointCommand:
        c, zero = self.config, np.zeros(constants.NUM_JOINTS)
        if self.phase is Phase.ZERO_TORQUE:
            return JointCommand(q=zero, kp=zero, kd=zero.copy())
        if self.phase is Phase.INTERPOLATE:
            alpha = min(max((now - self._t_phase) / c.interpolate_s, 0.0), 1.0)
            q_ref = self._q0 + alpha * (c.limits.default_q - self._q0)
        elif self.phase is Phase.HOLD or policy is None:
            q_ref = c.limits.default_q if self.phase is Phase.HOLD else self._last_q_ref
        else:
            if not np.isfinite(policy.obs).all():
                return self._fail(now, Fault.NONFINITE_OBSERVATION, "observation has NaN or inf")
            if not (np.isfinite(policy.action).all() and np.isfinite(policy.q_ref).all()):
                return self._fail(now, Fault.NONFINITE_ACTION, "action has NaN or inf")
            q_ref = np.clip(policy.q_ref, self._q_lo, self._q_hi)
        self._last_q_ref = np.asarray(q_ref, dtype=float).copy()
        return JointCommand(q=self._last_q_ref.copy(), kp=self._kp.copy(), kd=self._kd.copy())
