"""The rise from a crouch: CoM height and posture references along a minimum-jerk profile.

With both soles on the ground a crouch is the QP's home ground: the capture-point law
keeps ξ in the feet's polygon (stepping where it must) while the CoM height reference
h_ref(t) and the posture reference q_ref(t) go from the crouch (h₀, q₀) to the standing
pose (h*, q*) along one profile s(t):

    s(τ) = 10τ³ − 15τ⁴ + 6τ⁵,   τ = (t − t₀)/T ∈ [0, 1]
    h_ref(t) = h₀ + s (h* − h₀),   q_ref(t) = q₀ + s (q* − q₀)

(zero velocity and acceleration at both ends), T = (h* − h₀)/v̄ at a mean CoM speed v̄
(:meth:`~.config.RiseConfig.profile_duration`). :class:`~.balance_controller.
BalanceController` tracks them (:meth:`~.balance_controller.BalanceController.rise`).

A start that lands with the knees at their flexion limit can splay the knees through the
hips' yaw and roll (nearly parallel at ~95° of hip flexion) to their ranges; the QP then
raises the CoM with the pelvis pitched forward and stops short of h*. Such a locked rise
is unlocked by a stance reset (:class:`StanceReset`): ξ_ref is carried onto the sole
nearer the CoM, the other foot steps to the standing width beside it at the rise's
heading (:func:`reset_step_target`), and the profile starts again from where the robot
stands.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from hybrid_recovery.control.applicability import pelvis_tilt
from hybrid_recovery.control.config import RiseConfig
from hybrid_recovery.control.robot_state import RobotState
from hybrid_recovery.control.stepping import StepPlan
from hybrid_recovery.robot import constants

SHIFT, STEP = "shift", "step"
"""The phases of a :class:`StanceReset` under way."""


def min_jerk(tau: float) -> float:
    """s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ for τ clipped to [0, 1] [-]."""
    tau = min(max(tau, 0.0), 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau * tau)


def _default_pose(model: mujoco.MjModel) -> mujoco.MjData:
    """``model``'s data in q* with an upright pelvis at the origin, kinematics done."""
    data = mujoco.MjData(model)
    data.qpos[3] = 1.0  # identity quaternion of the free joint
    data.qpos[model.jnt_qposadr[1:1 + constants.NUM_JOINTS]] = constants.DEFAULT_JOINT_POS
    mujoco.mj_kinematics(model, data)
    return data


def standing_com_height(model: mujoco.MjModel) -> float:
    """h*: the CoM height above the soles of the default pose q* standing upright [m].

    Computed on ``model`` (upright pelvis, joints at ``constants.DEFAULT_JOINT_POS``) as
    the pelvis subtree CoM height minus the mean height of the sole sites
    ``left_foot`` and ``right_foot``.
    """
    data = _default_pose(model)
    mujoco.mj_comPos(model, data)
    soles = [data.site(f"{side}_foot").xpos[2] for side in ("left", "right")]
    return float(data.subtree_com[model.body("pelvis").id, 2] - np.mean(soles))


def standing_sole_width(model: mujoco.MjModel) -> float:
    """The lateral distance of the sole sites ``left_foot`` and ``right_foot`` in the
    default pose q* [m]."""
    data = _default_pose(model)
    return float(abs(data.site("left_foot").xpos[1] - data.site("right_foot").xpos[1]))


def reset_step_target(stance: np.ndarray, heading: np.ndarray, swing: int,
                      width: float) -> np.ndarray:
    """Where a stance reset puts the swing sole: ``width`` [m] beside the stance sole
    centre ``stance`` (2,) [m] along the heading's lateral axis (``heading`` R_z(ψ), (3, 3)),
    to its left for the left foot (``swing`` 0) and its right for the right (1): (2,) [m]."""
    side = 1.0 if swing == 0 else -1.0
    return np.asarray(stance, dtype=float)[:2] + side * width * heading[:2, 1]


def crouched_on_feet(state: RobotState, max_sole_height: float, min_com_height: float,
                     max_tilt: float) -> bool:
    """Whether a rise can start: both sole centres within ``max_sole_height`` [m] of the
    ground, no other part of the robot on it, the CoM at least ``min_com_height`` [m] up
    and the pelvis tilted less than ``max_tilt`` [rad] from vertical."""
    tilt = pelvis_tilt(state)
    return (all(foot.position[2] <= max_sole_height for foot in state.feet)
            and not state.non_foot_contact and float(state.com[2]) >= min_com_height
            and tilt <= max_tilt)


@dataclass(frozen=True)
class RiseTrajectory:
    """h_ref(t) and q_ref(t) of one rise (module docstring).

    Attributes:
        start: t₀ [s].
        duration: T [s].
        height: (h₀, h*) [m].
        posture: (q₀, q*), each shape (27,) [rad], motor order.
    """

    start: float
    duration: float
    height: tuple[float, float]
    posture: tuple[np.ndarray, np.ndarray]

    def phase(self, t: float) -> float:
        """s(t) [-]."""
        return min_jerk((t - self.start) / self.duration)

    def done(self, t: float) -> bool:
        """Whether t ≥ t₀ + T."""
        return t >= self.start + self.duration - 1e-9

    def height_ref(self, t: float) -> float:
        """h_ref(t) [m]."""
        low, high = self.height
        return low + self.phase(t) * (high - low)

    def posture_ref(self, t: float) -> np.ndarray:
        """q_ref(t), shape (27,) [rad]."""
        start, end = self.posture
        return start + self.phase(t) * (end - start)


@dataclass
class StanceReset:
    """The stance resets of one rise (module docstring).

    A rise is locked once its profile is over and the CoM has stayed below
    ``RiseConfig.end_com_height`` for ``stall_time``. A reset then carries ξ_ref onto the
    sole nearer the CoM (:data:`SHIFT`), steps the other foot to the standing width
    beside it (:data:`STEP`) and, once that foot has landed, the profile starts again.

    Attributes:
        count: Resets started in this rise (at most ``RiseConfig.max_resets``).
        stall_since: Since when the rise has stalled [s]; None while it has not.
        phase: :data:`SHIFT` or :data:`STEP` while a reset is under way, else None.
        swing: The foot that steps, 0 left / 1 right.
        start: When the reset under way started [s].
        shift_from: ξ_ref at its start, shape (2,) [m].
    """

    count: int = 0
    stall_since: float | None = None
    phase: str | None = None
    swing: int = 0
    start: float = 0.0
    shift_from: np.ndarray = field(default_factory=lambda: np.zeros(2))

    def locked(self, state: RobotState, t: float, cfg: RiseConfig) -> bool:
        """Whether the rise, its profile over, is locked at ``t`` [s] with resets left;
        runs the stall clock (stopped once the CoM is up or no reset is left)."""
        if state.com[2] >= cfg.end_com_height or self.count >= cfg.max_resets:
            self.stall_since = None
            return False
        self.stall_since = t if self.stall_since is None else self.stall_since
        return t - self.stall_since >= cfg.stall_time - 1e-9

    def begin(self, state: RobotState, t: float, xi_ref: np.ndarray) -> None:
        """Starts a reset at ``t`` [s] from ξ_ref ``xi_ref`` (2,) [m]: the foot farther
        from the CoM will step."""
        self.swing = int(np.argmax([np.linalg.norm(f.position[:2] - state.com[:2])
                                    for f in state.feet]))
        self.phase, self.start, self.shift_from = SHIFT, t, xi_ref.copy()
        self.count += 1

    def shift(self, state: RobotState, t: float, cfg: RiseConfig) -> tuple[np.ndarray, bool]:
        """ξ_ref at ``t`` [s], moved linearly onto the stance sole's centre over half of
        ``shift_time``, (2,) [m]; and whether the other foot lifts now: the CoM within
        ``shift_tolerance`` of that centre once ξ_ref is there, or ``shift_time`` up."""
        stance = state.feet[1 - self.swing].position[:2]
        ramp = min((t - self.start) / (0.5 * cfg.shift_time), 1.0) if cfg.shift_time > 0 else 1.0
        xi_ref = self.shift_from + ramp * (stance - self.shift_from)
        wait = ((ramp < 1.0 or np.linalg.norm(state.com[:2] - stance) > cfg.shift_tolerance)
                and t - self.start < cfg.shift_time - 1e-9)
        return xi_ref, not wait

    def step(self, state: RobotState, heading: np.ndarray, width: float) -> StepPlan:
        """The step of the other foot to ``width`` [m] beside the stance sole at the
        heading R_z(ψ) ``heading`` (3, 3) (:func:`reset_step_target`); the reset is then
        in :data:`STEP`."""
        stance = state.feet[1 - self.swing].position[:2]
        target = reset_step_target(stance, heading, self.swing, width)
        self.phase = STEP
        return StepPlan(self.swing, target, np.zeros((0, 2)), True, stance.copy(),
                        stance.copy())

    def finish(self) -> None:
        """The step has landed: no reset under way, the stall clock stopped."""
        self.phase, self.stall_since = None, None
