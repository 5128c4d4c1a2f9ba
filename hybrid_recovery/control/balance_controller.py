"""The QP balance controller: capture-point control with ankle, hip and stepping strategies.

Interface (shared with :class:`hybrid_recovery.control.supervisor.HybridSupervisor`)::

    controller = BalanceController(default_config())
    controller.reset(model, data)            # model from load_torque_model(): ctrl = τ
    for _ in range(n):
        data.ctrl[:] = controller(model, data)   # τ (27,) [N·m], motor order
        mujoco.mj_step(model, data)
    controller.diagnostics                   # the last tick's TickDiagnostics
    controller.events, controller.max_strategy

Each call (every physics step, 500 Hz at dt = 2 ms) reads the state, decides the phase
(double support, or swinging one foot in a capture step), turns the capture-point law
(:mod:`.dcm`) into a desired momentum rate, and solves the whole-body QP
(:mod:`.wbc_qp`). On the ground (low CoM, a non-foot contact or a large tilt) it
does not pretend: it reports ``applicable = False`` ("not applicable",
:mod:`.applicability`) and outputs joint damping only. From a crouch on both feet
:meth:`BalanceController.rise` stands the robot up (:mod:`.rise`): the same law and QP
with rising height and posture references.
"""

from __future__ import annotations

import dataclasses
import math
import time

import mujoco
import numpy as np

from hybrid_recovery.control.applicability import check_state, down_reason
from hybrid_recovery.control.config import BalanceConfig, default_config
from hybrid_recovery.control.dcm import DcmCommand, dcm_command, hip_reach
from hybrid_recovery.control.diagnostics import Capturability, Event, Strategy, TickDiagnostics
from hybrid_recovery.control.polygon import convex_hull, signed_distance_scalar
from hybrid_recovery.control.rise import (
    SHIFT,
    RiseTrajectory,
    StanceReset,
    crouched_on_feet,
    standing_com_height,
    standing_sole_width,
)
from hybrid_recovery.control.robot_state import RobotState, StateReader
from hybrid_recovery.control.stepping import (
    StepPlan,
    StepRecord,
    plan_for_swing,
    plan_step,
    step_capturability,
)
from hybrid_recovery.control.swing import SwingTrajectory
from hybrid_recovery.control.tasks import (
    momentum_tasks,
    pelvis_orientation_task,
    posture_task,
    swing_foot_task,
)
from hybrid_recovery.control.torque_model import check_torque_model
from hybrid_recovery.control.wbc_qp import QpSolution, Task, WholeBodyQP
from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.robot import constants

DOUBLE_SUPPORT = "double_support"
SWING = ("swing_left", "swing_right")
_UPPER_BODY = slice(12, 27)


def _yaw_rotation(rot: np.ndarray) -> np.ndarray:
    """R_z(ψ) with ψ the heading of rot's x axis."""
    yaw = np.arctan2(rot[1, 0], rot[0, 0])
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _mean_heading(rotations: list[np.ndarray]) -> np.ndarray:
    """R_z(ψ̄) with ψ̄ the circular mean of the headings of the rotations' x axes."""
    yaws = [np.arctan2(rot[1, 0], rot[0, 0]) for rot in rotations]
    yaw = np.arctan2(np.mean(np.sin(yaws)), np.mean(np.cos(yaws)))
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class BalanceController:
    """Whole-body QP balance controller (ankle, hip and stepping strategies).

    Args:
        config: Settings; :func:`default_config` when None.

    Attributes:
        diagnostics: The last tick's :class:`TickDiagnostics` (None before a call).
        events: Decisions since reset (steps, touchdowns, fallbacks, applicability).
        steps: One :class:`StepRecord` per step since reset.
        max_strategy: Highest balance :class:`Strategy` (STAND … STEP) used since reset.
        went_down: The QP stopped applying at some tick since reset (the robot fell).
    """

    def __init__(self, config: BalanceConfig | None = None) -> None:
        self.config = config or default_config()
        self.diagnostics: TickDiagnostics | None = None
        self.events: list[Event] = []
        self.steps: list[StepRecord] = []
        self.max_strategy = Strategy.STAND
        self.went_down = False
        self._reader: StateReader | None = None
        self._model: mujoco.MjModel | None = None
        self._qp: WholeBodyQP | None = None
        self._posture_ref: np.ndarray | None = None
        self._rise: RiseTrajectory | None = None
        self._standing: dict[int, tuple[float, float]] = {}  # model id → (h*, sole width)

    # ------------------------------------------------------------------ lifecycle
    def reset(self, model: mujoco.MjModel, data: mujoco.MjData,
              posture: np.ndarray | None = None) -> None:
        """Binds to ``model`` and takes the current stance as the reference.

        ξ_ref and the CoM height target are the current CoM; the pelvis heading is kept.
        ``posture`` (27,) [rad] is the joint posture the posture task holds (e.g. the
        stance another controller stood up in); None for the default pose q*.

        Raises:
            ValueError: Not a torque model (:data:`MODEL_MESSAGE`) or a non-finite state
                (:data:`~.applicability.NAN_STATE_MESSAGE`).
        """
        check_torque_model(model)
        check_state(data)
        if self._model is not model:
            self._qp = None
            scale = self.config.qp.torque_limit_scale
            self._reader = StateReader(model, (scale * float(constants.EFFORT_LIMITS[4]),
                                               scale * float(constants.EFFORT_LIMITS[5])))
            self._model = model
        if self._qp is None or self._qp.cfg is not self.config.qp:
            self._qp = WholeBodyQP(model.nv, self.config.qp, model.jnt_range[1:].copy())
        else:
            self._qp.reset()
        nj = constants.NUM_JOINTS
        self._posture_w = np.full(nj, self.config.qp.w_posture_legs)
        self._posture_w[_UPPER_BODY] = self.config.qp.w_posture_upper
        self._selector = np.hstack([np.zeros((nj, 6)), np.eye(nj)])
        self.events, self.max_strategy, self.diagnostics = [], Strategy.STAND, None
        self.went_down = False
        self.steps = []
        self._step_count = 0
        self._down = False
        self._last_status = "solved"
        self._posture_ref = None if posture is None else np.array(posture, dtype=float)
        self._rise = None
        self._stance_reset = StanceReset()
        self._init_references(self._read(data), float(data.time))

    def rise(self, model: mujoco.MjModel, data: mujoco.MjData) -> bool:
        """Resets and starts a rise from a crouch on both feet (:mod:`.rise`); False (and
        nothing started) where the state is no such crouch
        (:func:`~.rise.crouched_on_feet` with :class:`~.config.RiseConfig`'s bounds).

        ξ_ref is the midpoint of the soles; h_ref and q_ref go from the current CoM
        height and joints to the standing h* (:func:`~.rise.standing_com_height`) and q*
        over T (:meth:`~.config.RiseConfig.profile_duration`), then stay there. While
        rising the QP applies down to ``RiseConfig.min_com_height`` and up to
        ``RiseConfig.max_tilt``.
        """
        self.reset(model, data)
        cfg = self.config.rise
        state = self._read(data)
        if not crouched_on_feet(state, cfg.max_sole_height, cfg.min_com_height, cfg.max_tilt):
            return False
        if id(model) not in self._standing:
            self._standing[id(model)] = (standing_com_height(model), standing_sole_width(model))
        t, height = float(data.time), (float(state.com[2]), self._standing[id(model)][0])
        self._rise = RiseTrajectory(t, cfg.profile_duration(*height), height,
                                    (state.qpos[7:].copy(), constants.DEFAULT_JOINT_POS.copy()))
        self._xi_ref = np.mean([f.position[:2] for f in state.feet], axis=0)
        self._cmp_ref = self._xi_ref.copy()
        self._heading = _mean_heading([f.rotation for f in state.feet])
        self.qp.limit_margin = cfg.limit_margin
        self.events.append(Event(t, "rise", f"rise from CoM height {state.com[2]:.2f} m to "
                                 f"{self._rise.height[1]:.2f} m over {self._rise.duration:.1f} s"))
        return True

    @property
    def rising(self) -> bool:
        """A rise (:meth:`rise`) is under way."""
        return self._rise is not None

    @property
    def qp(self) -> WholeBodyQP:
        """The whole-body QP (after reset), e.g. to record its problems."""
        assert self._qp is not None, "call reset(model, data) first"
        return self._qp

    def _init_references(self, state: RobotState, t: float) -> None:
        self._height_ref = float(state.com[2])
        self._xi_ref = state.com[:2].copy()
        self._cmp_ref = self._xi_ref.copy()
        self._heading = _yaw_rotation(state.pelvis_rotation)
        self._phase = DOUBLE_SUPPORT
        self._swing: SwingTrajectory | None = None
        self._plan: StepPlan | None = None
        self._swing_heading = np.eye(3)
        self._t_touchdown = t

    def _read(self, data: mujoco.MjData) -> RobotState:
        assert self._reader is not None, "call reset(model, data) first"
        return self._reader.read(data)

    # ------------------------------------------------------------------ the tick
    def _begin(self, model: mujoco.MjModel, data: mujoco.MjData):
        """Checks and reads the state (resetting on a new model): (state, t, down reason)."""
        check_state(data)
        if self._model is not model:
            self.reset(model, data)
        state = self._read(data)
        return state, float(data.time), self.down_reason(state)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """One control tick: joint torques τ, shape (27,) [N·m], motor order.

        Raises:
            ValueError: On a non-finite state (:data:`~.applicability.NAN_STATE_MESSAGE`).
        """
        start = time.perf_counter()
        state, t, reason = self._begin(model, data)
        if self._rise is not None:
            self._follow_rise(state, t)
        if reason:
            return self._not_applicable(state, t, reason, start)
        if self._down:  # back up (e.g. after the policy): start over from this stance
            self._down = False
            self._init_references(state, t)
            self.events.append(Event(t, "applicable", "standing again: QP resumes"))
        contact = [f.normal_force > self.config.foot_contact_force for f in state.feet]
        self._update_swing(state, t, contact)
        support = self._support(state)
        cmd = self._dcm(state, t, support)
        outside = float(signed_distance_scalar(cmd.capture_point, support))  # d(ξ, C)
        if self._phase == DOUBLE_SUPPORT:
            plan = self._step_plan(state, t, cmd, support, outside)
            if plan is not None:
                self._start_step(state, t, cmd.capture_point, plan)
                support = self._support(state)
                cmd = self._dcm(state, t, support)
                outside = float(signed_distance_scalar(cmd.capture_point, support))
        stance = (True, True) if self._phase == DOUBLE_SUPPORT else (
            self._phase != SWING[0], self._phase != SWING[1])
        solution = self.qp.solve(state, self._tasks(state, cmd, t), stance)
        self._log_status(solution, t)
        strategy = self._strategy(cmd)
        self.max_strategy = max(self.max_strategy, strategy)
        margin = -outside
        self.diagnostics = TickDiagnostics(
            time=t, applicable=True, reason="", strategy=strategy,
            capturability=self._capturability(state, cmd, support, margin, t),
            phase=self._phase, capture_point=cmd.capture_point, cop=cmd.cop, cmp=cmd.cmp,
            margin=margin, com=state.com, com_vel=state.com_vel, qp_status=solution.status,
            solve_time=solution.solve_time, qp_iterations=solution.iterations,
            tick_time=time.perf_counter() - start,
            steps=self._step_count,
        )
        return solution.torque

    def assess(self, model: mujoco.MjModel, data: mujoco.MjData) -> TickDiagnostics:
        """Capturability of the current state without solving the QP (for a supervisor).

        Uses the stance and references of the last reset; ``strategy`` is the one the
        controller would start from.
        """
        state, t, reason = self._begin(model, data)
        if reason:
            return TickDiagnostics(t, False, reason, Strategy.NOT_APPLICABLE,
                                   Capturability.NONE, self._phase, com=state.com,
                                   com_vel=state.com_vel)
        support = convex_hull(np.concatenate([f.cop_corners[:, :2] for f in state.feet]))
        xi_ref = np.mean([f.position[:2] for f in state.feet], axis=0)
        cmd = dcm_command(state.com, state.com_vel, state.angular_momentum, xi_ref, xi_ref,
                          support, self._height_ref, state.mass, self.config.dcm)
        margin = -float(signed_distance_scalar(cmd.capture_point, support))
        return TickDiagnostics(t, True, "", self._strategy(cmd),
                               self._capturability(state, cmd, support, margin, t, planning=True),
                               DOUBLE_SUPPORT, cmd.capture_point, cmd.cop, cmd.cmp, margin,
                               com=state.com, com_vel=state.com_vel)

    def _follow_rise(self, state: RobotState, t: float) -> None:
        """Moves h_ref and q_ref along the rise; ends it (q_ref = q*) once the profile is
        complete and the robot stands (``RiseConfig.end_com_height``, ``end_tilt``)."""
        assert self._rise is not None
        self._height_ref = self._rise.height_ref(t)
        self._posture_ref = self._rise.posture_ref(t)
        cfg = self.config.rise
        if self._rise.done(t) and not down_reason(state, cfg.end_com_height, cfg.end_tilt):
            self._rise, self._posture_ref = None, None
            self.qp.limit_margin = self.config.qp.limit_margin
            self.events.append(Event(t, "risen", f"standing: CoM height {state.com[2]:.2f} m"))
        elif self._rise.done(t) and self._phase == DOUBLE_SUPPORT:
            self._reset_stance(state, t)

    def _reset_stance(self, state: RobotState, t: float) -> None:
        """A locked rise (:class:`~.rise.StanceReset`; ``RiseConfig.stall_time``): ξ_ref
        moved onto the sole nearer the CoM, the other foot stepped to the standing width
        beside it, then the profile again from the stance it lands in."""
        assert self._rise is not None and self._model is not None
        cfg, reset = self.config.rise, self._stance_reset
        if reset.phase is None:
            if reset.locked(state, t, cfg):
                reset.begin(state, t, self._xi_ref)
                self.events.append(Event(t, "stance_reset", f"locked at CoM height "
                                         f"{state.com[2]:.2f} m: the CoM onto the "
                                         f"{('right', 'left')[reset.swing]} foot"))
        elif reset.phase == SHIFT:
            self._xi_ref, lift = reset.shift(state, t, cfg)
            self._cmp_ref = self._xi_ref.copy()
            if lift:
                plan = reset.step(state, self._heading, self._standing[id(self._model)][1])
                self._start_step(state, t, plan.stance_cop, plan)
                self._swing_heading = self._heading.copy()
        else:  # the step has landed (double support again): the profile from this stance
            reset.finish()
            height = (float(state.com[2]), self._rise.height[1])
            self._rise = RiseTrajectory(t, cfg.profile_duration(*height), height,
                                        (state.qpos[7:].copy(), self._rise.posture[1]))
            self.events.append(Event(t, "rise",
                                     f"rise again from CoM height {state.com[2]:.2f} m"))

    # ------------------------------------------------------------------ applicability
    def down_reason(self, state: RobotState) -> str:
        """Why the QP does not apply ("" when it does): low CoM, non-foot contact, tilt
        (while rising with :class:`~.config.RiseConfig`'s bounds)."""
        bounds = self.config if self._rise is None else self.config.rise
        return down_reason(state, bounds.min_com_height, bounds.max_tilt)

    def _not_applicable(self, state: RobotState, t: float, reason: str, start: float
                        ) -> np.ndarray:
        if not self._down:
            self.events.append(Event(t, "not_applicable", reason))
            self._down = True
        if self._rise is not None:
            self.events.append(Event(t, "rise_failed", reason))
            self._rise = None
            self.qp.limit_margin = self.config.qp.limit_margin
        self.went_down = True
        self.diagnostics = TickDiagnostics(
            time=t, applicable=False, reason=reason, strategy=Strategy.NOT_APPLICABLE,
            capturability=Capturability.NONE, phase=self._phase, com=state.com,
            com_vel=state.com_vel, tick_time=time.perf_counter() - start,
            steps=self._step_count)
        torque = -self.config.damping_gain * constants.KD * state.qvel[6:]
        return np.clip(torque, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)

    # ------------------------------------------------------------------ phases
    def _support(self, state: RobotState) -> np.ndarray:
        feet = [0, 1] if self._phase == DOUBLE_SUPPORT else [1 - SWING.index(self._phase)]
        return convex_hull([xy for i in feet for xy in state.feet[i].cop_corners[:, :2].tolist()])

    def _dcm(self, state: RobotState, t: float, support: np.ndarray) -> DcmCommand:
        cfg = self.config
        xi_ref, cmp_ref = self._xi_ref, self._cmp_ref
        if self._plan is not None and self._swing is not None:
            omega = np.sqrt(GRAVITY / max(state.com[2], 0.1))
            plan = self._plan
            offset = plan.capture_at_touchdown - plan.target
            norm = np.linalg.norm(offset)
            if norm > cfg.stepping.foot_size:
                offset *= cfg.stepping.foot_size / norm
            xi_end = plan.target + offset
            remaining = max(self._swing.t_end - t, 0.0)
            cmp_ref = plan.stance_cop
            xi_ref = cmp_ref + (xi_end - cmp_ref) * np.exp(-omega * remaining)
        return dcm_command(state.com, state.com_vel, state.angular_momentum, xi_ref, cmp_ref,
                           support, self._height_ref, state.mass, cfg.dcm)

    def _hip_reach(self, cmd: DcmCommand, mass: float) -> float:
        fz = mass * (GRAVITY + cmd.com_acc[2])
        return hip_reach(cmd.omega, max(fz, 1.0), self.config.dcm)

    def _step_plan(self, state: RobotState, t: float, cmd: DcmCommand, support: np.ndarray,
                   outside: float) -> StepPlan | None:
        """A step to take now, or None (``outside``: d(ξ, C) [m], signed distance of ξ to
        the support polygon C).

        Step when ξ is farther outside C than ``hip_margin_scale`` × the hip's reach, is
        not coming back under the commanded CMP (ξ̇ = ω (ξ − r_cmp) points away from C),
        and a single step captures; or when ξ is farther out than the full reach (then the
        best step, even one that does not capture on its own). Never while the stance
        sole carries no load (``foot_contact_force``): a start still landing.
        """
        cfg = self.config.stepping
        if not cfg.enabled or self._step_count >= cfg.max_steps:
            return None
        if t - self._t_touchdown < cfg.min_double_support and self._step_count > 0:
            return None
        reach = self._hip_reach(cmd, state.mass)
        if outside <= cfg.hip_margin_scale * reach:
            return None
        ahead = cmd.cmp + (cmd.capture_point - cmd.cmp) * np.exp(cmd.omega * cfg.lookahead)
        if outside <= reach and float(signed_distance_scalar(ahead, support)) < outside:
            return None  # ξ is coming back: the hip strategy is working
        xy, corners, rots = self._feet_arrays(state)
        plan = plan_step(cmd.capture_point, cmd.omega, xy, corners, rots, cfg,
                         self.config.dcm.cop_margin)
        if state.feet[1 - plan.swing].normal_force <= self.config.foot_contact_force:
            return None  # its stance sole is in the air (e.g. a start still landing)
        return plan if plan.capturable or outside > reach else None

    def _feet_arrays(self, state: RobotState):
        xy = np.array([f.position[:2] for f in state.feet])
        corners = np.array([f.cop_corners for f in state.feet])
        rots = np.array([f.rotation for f in state.feet])
        return xy, corners, rots

    def _start_step(self, state: RobotState, t: float, capture_point: np.ndarray,
                    plan: StepPlan) -> None:
        cfg = self.config.stepping
        foot = state.feet[plan.swing]
        self._plan = plan
        self._swing = SwingTrajectory(foot.position, np.array([*plan.target, -cfg.touchdown_depth]),
                                      t, cfg.swing_time, cfg.swing_height)
        self._swing_heading = _yaw_rotation(foot.rotation)
        self._phase = SWING[plan.swing]
        self._t_replan = t
        self.steps.append(StepRecord(t, plan.swing, plan, plan))
        side = ("left", "right")[plan.swing]
        self.events.append(Event(
            t, "step", f"{side} foot to ({plan.target[0]:.3f}, {plan.target[1]:.3f}) m, "
            f"xi = ({capture_point[0]:.3f}, {capture_point[1]:.3f}) m, "
            f"{'inside' if plan.capturable else 'outside'} the 1-step capture region"))

    def _update_swing(self, state: RobotState, t: float, contact: list[bool]) -> None:
        if self._swing is None or self._plan is None:
            return
        cfg = self.config.stepping
        swing = self._plan.swing
        s = self._swing.phase(t)
        landed = s >= 0.5 and state.feet[swing].normal_force > cfg.touchdown_force
        if landed or s >= cfg.touchdown_timeout:
            self._phase = DOUBLE_SUPPORT
            self._t_touchdown = t
            self._step_count += 1
            self._xi_ref = np.mean([f.position[:2] for f in state.feet], axis=0)
            self._cmp_ref = self._xi_ref.copy()
            pos = state.feet[swing].position
            if self.steps:
                self.steps[-1].touchdown_time, self.steps[-1].touchdown = t, pos[:2].copy()
            self.events.append(Event(t, "touchdown", f"{('left', 'right')[swing]} foot at "
                                     f"({pos[0]:.3f}, {pos[1]:.3f}) m, step {self._step_count}"))
            self._swing, self._plan = None, None
            return
        if s < cfg.replan_until and t - self._t_replan >= cfg.replan_period - 1e-9:
            self._t_replan = t
            xy, corners, rots = self._feet_arrays(state)
            omega = float(np.sqrt(GRAVITY / max(state.com[2], 0.1)))
            xi = state.com[:2] + state.com_vel[:2] / omega
            plan = plan_for_swing(swing, xi, omega, xy, corners[1 - swing], rots[1 - swing],
                                  self._swing.t_end - t, cfg, self.config.dcm.cop_margin)
            self._plan = plan
            if self.steps:
                self.steps[-1].last_plan = plan
            self._swing.retarget(t, np.array([*plan.target, -cfg.touchdown_depth]))

    # ------------------------------------------------------------------ tasks
    def _tasks(self, state: RobotState, cmd: DcmCommand, t: float) -> list[Task]:
        cfg = self.config.qp
        pelvis = pelvis_orientation_task(state, self._heading, cfg)
        if self._rise is not None:
            pelvis = dataclasses.replace(pelvis, weight=self.config.rise.w_pelvis_orientation)
        tasks = [*momentum_tasks(state, cmd, cfg), pelvis,
                 posture_task(state, self._selector, self._posture_w, cfg, self._posture_ref)]
        if self._swing is not None and self._plan is not None:
            tasks.append(swing_foot_task(state.feet[self._plan.swing], self._swing.sample(t),
                                         self._swing_heading, cfg))
        return tasks

    # ------------------------------------------------------------------ labels
    def _strategy(self, cmd: DcmCommand) -> Strategy:
        d = self.config.dcm
        if self._phase != DOUBLE_SUPPORT:
            return Strategy.STEP
        if cmd.hip_offset > d.hip_threshold:
            return Strategy.HIP
        (dx, dy), (rx, ry) = cmd.cmp_desired.tolist(), self._xi_ref.tolist()
        dx, dy = dx - rx, dy - ry
        if math.sqrt(dx * dx + dy * dy) > d.ankle_threshold:  # ‖r_cmp,des − ξ_ref‖
            return Strategy.ANKLE
        return Strategy.STAND

    def _capturability(self, state: RobotState, cmd: DcmCommand, support: np.ndarray,
                       margin: float, t: float, planning: bool = False) -> Capturability:
        reach = self._hip_reach(cmd, state.mass)
        if margin >= -reach:
            return Capturability.ZERO_STEP if margin >= 0.0 else Capturability.HIP
        cfg = self.config.stepping
        if not cfg.enabled or self._step_count >= cfg.max_steps:
            return Capturability.NONE
        xy, corners, rots = self._feet_arrays(state)
        if self._plan is not None and self._swing is not None and not planning:
            plan = self._plan  # ξ at touchdown predicted from now, CoP held at the stance
            remaining = max(self._swing.t_end - t, 0.0)
            xi_td = plan.stance_cop + (cmd.capture_point - plan.stance_cop) * np.exp(
                cmd.omega * remaining)
            plan = dataclasses.replace(plan, capture_at_touchdown=xi_td)
        else:
            plan = plan_step(cmd.capture_point, cmd.omega, xy, corners, rots, cfg,
                             self.config.dcm.cop_margin)
        return step_capturability(plan, xy, corners[1 - plan.swing], reach, cmd.omega,
                                  cfg.max_steps - self._step_count - 1, cfg)

    def _log_status(self, solution: QpSolution, t: float) -> None:
        if solution.status != self._last_status:
            kind = "qp_ok" if solution.status == "solved" else "fallback"
            self.events.append(Event(t, kind, f"QP status {solution.status}"))
            self._last_status = solution.status
