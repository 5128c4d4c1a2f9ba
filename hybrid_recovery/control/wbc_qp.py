"""Torque-level whole-body QP over joint accelerations and sole-corner forces (proxsuite).

Decision variables x = [q̈ (nv); ρ (16 per stance foot)]: each sole corner i carries a
force f_i = B ρ_i, B (3, 4) the edges of the inner linearised friction pyramid
(μ cos θ_k, μ sin θ_k, 1)/√(1 + μ²), θ_k = 0, π/2, π, 3π/2, so that ρ ≥ 0 is the friction
cone and, with all corners, keeps the CoP inside the sole. With G = Σ_i J_iᵀ B (nv, ·),
J_i the corner Jacobians, and S = [0 I] selecting the actuated rows:

    min  Σ_k w_k ‖J_k q̈ − b_k‖² + w_q̈ ‖q̈‖² + w_ρ ‖ρ‖²
    s.t. M_u q̈ − G_u ρ = −h_u                          (floating base, 6 rows)
         J_foot q̈ = −J̇_foot q̇ − k_c v_foot            (each stance sole, 6 rows)
         −τ_max ≤ M_a q̈ + h_a − G_a ρ ≤ τ_max          (27 torque rows)
         q̈_lo ≤ q̈_a ≤ q̈_hi                            (joint position limits)
         0 ≤ ρ ≤ ρ_max

The joint-limit box keeps q + q̇ T + q̈ T²/2 inside the range shrunk by a margin, T the
limit horizon: q̈_lo = 2 (q_lo + δ − q − q̇ T)/T², likewise q̈_hi.

and τ = M_a q̈ + h_a − G_a ρ. One dense proxsuite QP object per contact mode (both,
left or right sole), warm-started from its previous solution; the problem's arrays are
kept per contact mode too, their constant blocks written once.

Fallbacks (reported in :attr:`QpSolution.status`): ``"relaxed"`` — the torque rows and
the joint-limit box are dropped and the torques clipped; ``"last_good"`` — the last good
torques are repeated; ``"damping"`` — no good command yet: τ = −K_D q̇. Torques are
always finite and inside ±τ_max.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from hybrid_recovery.control.applicability import all_finite
from hybrid_recovery.control.config import QpConfig
from hybrid_recovery.control.proxsuite_build import proxsuite
from hybrid_recovery.control.robot_state import RobotState
from hybrid_recovery.robot import constants

_BIG = 1e10
_SOLVED = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
_WARM_START = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
_EQUALITY_GUESS = proxsuite.proxqp.InitialGuess.EQUALITY_CONSTRAINED_INITIAL_GUESS


@dataclass
class Task:
    """A least-squares task w ‖J q̈ − b‖² on the joint accelerations.

    Attributes:
        name: For diagnostics.
        jacobian: J, shape (k, nv).
        target: b, shape (k,).
        weight: w, a float or shape (k,).
    """

    name: str
    jacobian: np.ndarray
    target: np.ndarray
    weight: float | np.ndarray


@dataclass
class QpSolution:
    """One tick's command.

    Attributes:
        torque: τ in motor order, shape (27,) [N·m], finite, inside ±τ_max.
        qacc: q̈ of the solution, shape (nv,); zeros for fallbacks without a QP solution.
        corner_forces: f per (foot, corner), world frame, shape (2, 4, 3) [N].
        status: ``"solved"``, ``"relaxed"``, ``"last_good"`` or ``"damping"``.
        solve_time: Wall time of the proxsuite update + solve calls [s].
        iterations: proxsuite iterations of the accepted solve (0 for fallbacks).
    """

    torque: np.ndarray
    qacc: np.ndarray
    corner_forces: np.ndarray
    status: str
    solve_time: float
    iterations: int


@dataclass
class QpProblem:
    """One nominal QP in proxsuite's form (for benchmarks):
    min ½ xᵀ H x + gᵀ x  s.t.  A x = b,  lower ≤ C x ≤ upper,  box_lower ≤ x ≤ box_upper."""

    stance: tuple[bool, bool]
    hessian: np.ndarray
    gradient: np.ndarray
    a_eq: np.ndarray
    b_eq: np.ndarray
    c_in: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    box_lower: np.ndarray
    box_upper: np.ndarray

    def args(self) -> tuple[np.ndarray, ...]:
        """(H, g, A, b, C, l, u, l_box, u_box) in proxsuite's argument order."""
        return (self.hessian, self.gradient, self.a_eq, self.b_eq, self.c_in, self.lower,
                self.upper, self.box_lower, self.box_upper)

    def copy(self) -> QpProblem:
        """The same problem in arrays of its own."""
        return QpProblem(self.stance, *(array.copy() for array in self.args()))


@dataclass
class _TickBlocks:
    """Views of the parts of a :class:`QpProblem` that change every tick (slicing them
    once saves a view per block per tick); nv velocities, n = nv + nf variables.

    Attributes:
        hessian_qacc: H_q̈q̈, shape (nv, nv). qacc_diagonal: its diagonal, shape (nv,).
        gradient_qacc: g_q̈, shape (nv,).
        base_mass: A[:6, :nv]; base_forces: A[:6, nv:]; base_rhs: b[:6].
        sole_rows: (A rows, b rows) of each stance sole, shapes (6, nv) and (6,).
        torque_mass: C[:, :nv], shape (27, nv); torque_forces: C[:, nv:], shape (27, nf).
        limit_box: [box_lower; box_upper] of the actuated q̈, shape (2, 27) [rad/s²].
    """

    hessian_qacc: np.ndarray
    qacc_diagonal: np.ndarray
    gradient_qacc: np.ndarray
    base_mass: np.ndarray
    base_forces: np.ndarray
    base_rhs: np.ndarray
    sole_rows: list[tuple[np.ndarray, np.ndarray]]
    torque_mass: np.ndarray
    torque_forces: np.ndarray
    limit_box: np.ndarray


@dataclass
class _ProblemBuffers:
    """The arrays of one contact mode's QP, kept from tick to tick.

    Attributes:
        problem: The :class:`QpProblem`; its arrays are views of ``flat``.
        flat: All of the problem's entries, to check them at once.
        torque_bounds: [lower; upper] of the torque rows, a view, shape (2, 27) [N·m].
        box: [box_lower; box_upper], a view, shape (2, nv + nf).
        relaxed: (lower, upper, box_lower, box_upper) of the relaxed problem: torque rows
            and joint limits free.
        built_with: (w_ρ, ρ_max) of the constant blocks.
        blocks: Views of the blocks written every tick (:func:`_tick_blocks`).
    """

    problem: QpProblem
    flat: np.ndarray
    torque_bounds: np.ndarray
    box: np.ndarray
    relaxed: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    built_with: tuple[float, float]
    blocks: _TickBlocks


def _tick_blocks(problem: QpProblem, box: np.ndarray, nv: int) -> _TickBlocks:
    """The :class:`_TickBlocks` of ``problem`` (box: its (2, n) bounds)."""
    hess, a_eq, b_eq, c_in = problem.hessian, problem.a_eq, problem.b_eq, problem.c_in
    n = hess.shape[0]
    return _TickBlocks(
        hess[:nv, :nv], hess.reshape(-1)[: nv * (n + 1) : n + 1], problem.gradient[:nv],
        a_eq[:6, :nv], a_eq[:6, nv:], b_eq[:6],
        [(a_eq[row : row + 6, :nv], b_eq[row : row + 6]) for row in range(6, len(b_eq), 6)],
        c_in[:, :nv], c_in[:, nv:], box[:, 6:nv])


def _problem_buffers(stance: tuple[bool, bool], nv: int, nf: int, w_force: float,
                    max_force: float) -> _ProblemBuffers:
    """:class:`_ProblemBuffers` of the balance QP for a stance with ``nf`` force variables,
    with the blocks that do not depend on the state written: H_ρρ = w_ρ I, zero couplings
    of q̈ and ρ, g_ρ = 0, zero ρ columns of the sole rows, the free base's ±10¹⁰ box and
    0 ≤ ρ ≤ ρ_max (``max_force`` [N])."""
    n, n_in, n_eq = nv + nf, nv - 6, 6 + 6 * sum(stance)
    sizes = (n * n, n, n_eq * n, n_eq, n_in * n, 2 * n_in, 2 * n)
    flat = np.zeros(sum(sizes))
    hess, grad, a_eq, b_eq, c_in, rows, box = np.split(flat, np.cumsum(sizes)[:-1])
    hess, a_eq, c_in = hess.reshape(n, n), a_eq.reshape(n_eq, n), c_in.reshape(n_in, n)
    rows, box = rows.reshape(2, n_in), box.reshape(2, n)
    hess[nv:, nv:] = w_force * np.eye(nf)
    box[0], box[1] = free_bounds(nv, nf, max_force)
    problem = QpProblem(stance, hess, grad, a_eq, b_eq, c_in, rows[0], rows[1], box[0], box[1])
    relaxed = (np.full(n_in, -_BIG), np.full(n_in, _BIG), *free_bounds(nv, nf, max_force))
    return _ProblemBuffers(problem, flat, rows, box, relaxed, (w_force, max_force),
                           _tick_blocks(problem, box, nv))


def torque_rows(state: RobotState, g_map: np.ndarray, tau_max: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The actuated rows τ = M_a q̈ + h_a − G_a ρ = C x + h_a over x = [q̈; ρ] with the
    bounds −τ_max ≤ τ ≤ τ_max as lo ≤ C x ≤ hi.

    Returns:
        (C (27, nv + nf), h_a (27,) [N·m], lo (27,), hi (27,)).
    """
    c_in = np.hstack([state.mass_matrix[6:], -g_map[6:]])
    h_a = state.bias[6:]
    return c_in, h_a, -tau_max - h_a, tau_max - h_a


def free_bounds(nv: int, nf: int, max_force: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of x = [q̈ (nv); ρ (nf)] without joint limits: q̈ free, 0 ≤ ρ ≤ max_force."""
    return (np.concatenate([np.full(nv, -_BIG), np.zeros(nf)]),
            np.concatenate([np.full(nv, _BIG), np.full(nf, max_force)]))


def stack_tasks(tasks: list[Task]) -> tuple[np.ndarray, np.ndarray]:
    """(√w J, √w b) of all tasks stacked, shapes (Σk, nv) and (Σk,): Σ w ‖J q̈ − b‖² is
    ‖(√w J) q̈ − √w b‖² (each block written in place, no concatenation)."""
    sizes = [len(t.target) for t in tasks]
    total = sum(sizes)
    rows = np.empty((total, tasks[0].jacobian.shape[1]))
    rhs = np.empty(total)
    start = 0
    for t, size in zip(tasks, sizes, strict=True):
        block, target = rows[start : start + size], rhs[start : start + size]
        start += size
        weight = t.weight
        if isinstance(weight, (float, int)) and weight >= 0.0:  # √w as a float: fewer calls
            root = math.sqrt(weight)
            np.multiply(root, t.jacobian, out=block)
            np.multiply(root, t.target, out=target)
            continue
        if np.shape(weight) != t.target.shape:
            weight = np.broadcast_to(np.asarray(weight, float), t.target.shape)
        roots = np.sqrt(weight, dtype=float)
        np.multiply(roots[:, None], t.jacobian, out=block)
        np.multiply(roots, t.target, out=target)
    return rows, rhs


def pyramid_basis(mu: float) -> np.ndarray:
    """B, shape (3, 4): unit edges of the inner friction pyramid of a flat ground (z up)."""
    theta = np.arange(4) * np.pi / 2
    edges = np.stack([mu * np.cos(theta), mu * np.sin(theta), np.ones(4)])
    return edges / np.sqrt(1.0 + mu * mu)


class WholeBodyQP:
    """The QP above for a robot with ``nv`` velocities and 27 actuated joints.

    Args:
        nv: Velocity dimension (6 + 27).
        cfg: Weights, gains, limits and solver settings.
        joint_range: Joint position limits (q_lo, q_hi) in motor order, shape (27, 2) [rad].
    """

    def __init__(self, nv: int, cfg: QpConfig, joint_range: np.ndarray) -> None:
        if cfg.friction <= 0.0:
            raise ValueError("QpConfig.friction must be > 0")
        if cfg.torque_limit_scale <= 0.0:
            raise ValueError("QpConfig.torque_limit_scale must be > 0")
        self.nv, self.cfg = nv, cfg
        self.basis = pyramid_basis(cfg.friction)
        self.tau_max = constants.EFFORT_LIMITS * cfg.torque_limit_scale
        joint_range = np.asarray(joint_range, dtype=float)
        if joint_range.shape != (nv - 6, 2):
            raise ValueError(f"joint_range must have shape ({nv - 6}, 2), got {joint_range.shape}")
        self.joint_range = joint_range
        self.limit_margin = cfg.limit_margin
        """δ [rad]: the box keeps q inside the ranges shrunk by δ (:meth:`reset` restores
        ``cfg.limit_margin``; the balance controller's rise sets its own)."""
        # One dense QP per (stance, relaxed): the problem size depends on the stance.
        self._qps: dict[tuple[tuple[bool, bool], bool], proxsuite.proxqp.dense.QP] = {}
        self._fresh: dict[tuple[tuple[bool, bool], bool], bool] = {}
        self._buffers: dict[tuple[bool, bool], _ProblemBuffers] = {}
        self._limits = np.zeros((2, nv - 6))
        self._limits_margin = math.nan
        self._tau_bounds = np.stack([-self.tau_max, self.tau_max])
        self._effort_low = -constants.EFFORT_LIMITS
        self.last_good: np.ndarray | None = None
        self.recorder: list[QpProblem] | None = None
        """Set to a list to record every nominal problem (benchmarks)."""

    @property
    def q_lo(self) -> np.ndarray:
        """q_lo + δ, shape (27,) [rad]."""
        return self.joint_range[:, 0] + self.limit_margin

    @property
    def q_hi(self) -> np.ndarray:
        """q_hi − δ, shape (27,) [rad]."""
        return self.joint_range[:, 1] - self.limit_margin

    def reset(self) -> None:
        """Forgets warm starts and the last good command; the margin is the config's."""
        self.limit_margin = self.cfg.limit_margin
        self._qps.clear()
        self._fresh.clear()
        self._buffers.clear()
        self.last_good = None

    # ------------------------------------------------------------------ problem
    def _contact_map(self, state: RobotState, stance: tuple[bool, bool]) -> np.ndarray:
        """G = Σ J_iᵀ B over the stance corners, shape (nv, 16 · #stance) (a transposed
        view: einsum into Gᵀ's own order is the faster one)."""
        blocks = [state.feet[s].corner_jacobians for s in (0, 1) if stance[s]]
        jacobians = blocks[0] if len(blocks) == 1 else np.concatenate(blocks)
        return np.einsum("kdn,dj->kjn", jacobians, self.basis).reshape(-1, self.nv).T

    def _problem(self, stance: tuple[bool, bool], nf: int) -> _ProblemBuffers:
        """This stance's :func:`_problem_buffers` (rebuilt when w_ρ or ρ_max changed)."""
        built_with = (self.cfg.w_force, self.cfg.max_corner_force)
        buffers = self._buffers.get(stance)
        if buffers is None or buffers.built_with != built_with:
            buffers = _problem_buffers(stance, self.nv, nf, *built_with)
            self._buffers[stance] = buffers
        return buffers

    def _joint_limits(self) -> np.ndarray:
        """[q_lo + δ; q_hi − δ], shape (2, 27) [rad], recomputed when δ changes."""
        if self.limit_margin != self._limits_margin:
            self._limits = np.stack([self.q_lo, self.q_hi])
            self._limits_margin = self.limit_margin
        return self._limits

    def _qp(self, key: tuple[tuple[bool, bool], bool], n: int, n_eq: int):
        if key not in self._qps:
            qp = proxsuite.proxqp.dense.QP(n, n_eq, self.nv - 6, True)
            # The first solve starts from the equality-constrained guess (deterministic);
            # warm starting is switched on after it (proxsuite 0.8 segfaults when warm start
            # is requested between init and the first solve, and a warm start set before
            # init starts from uninitialised memory).
            qp.settings.initial_guess = _EQUALITY_GUESS
            qp.settings.eps_abs = self.cfg.eps_abs
            qp.settings.eps_rel = 0.0
            qp.settings.max_iter = self.cfg.max_iter
            qp.settings.max_iter_in = self.cfg.max_iter
            qp.settings.verbose = False
            self._qps[key] = qp
            self._fresh[key] = True
        return self._qps[key]

    def solve(self, state: RobotState, tasks: list[Task], stance: tuple[bool, bool]
              ) -> QpSolution:
        """Solves the tick's QP, with the fallbacks of the module docstring.

        Args:
            state: The tick's :class:`RobotState`.
            tasks: Least-squares tasks on q̈.
            stance: Which soles are in contact (left, right); at least one.

        Returns:
            The :class:`QpSolution`.
        """
        if not any(stance):
            raise ValueError("WholeBodyQP.solve needs at least one stance foot")
        g_map = self._contact_map(state, stance)
        n, nf = self.nv + g_map.shape[1], g_map.shape[1]
        buffers = self._problem(stance, nf)
        self._write_problem(buffers.blocks, state, tasks, stance, g_map)
        c_in, h_a = buffers.problem.c_in, state.bias[6:]
        np.subtract(self._tau_bounds, h_a, out=buffers.torque_bounds)

        start = time.perf_counter()
        if not all_finite(buffers.flat):  # never hand NaN or inf to the solver
            return self.fallback(state)
        p = buffers.problem
        if self.recorder is not None:
            self.recorder.append(p.copy())
        args = p.args()
        for relaxed in (False, True):
            key = (stance, relaxed)
            qp = self._qp(key, n, len(p.b_eq))
            bounds = buffers.relaxed if relaxed else args[5:]
            fresh = self._fresh[key]
            if fresh:
                qp.init(*args[:5], *bounds)
            else:
                qp.update(*args[:5], *bounds)
            qp.solve()
            if fresh:
                qp.settings.initial_guess = _WARM_START
                self._fresh[key] = False
            results = qp.results
            x, info = results.x, results.info
            ok = info.status == _SOLVED and all_finite(x)
            if not ok:  # a failed solve spoils the warm start: next time, a cold QP
                del self._qps[key]
                continue
            solve_time = time.perf_counter() - start
            torque = np.minimum(np.maximum(c_in @ x + h_a, self._effort_low),
                                constants.EFFORT_LIMITS)
            if all_finite(torque):
                self.last_good = torque.copy()
                return QpSolution(torque, x[: self.nv].copy(), self._forces(x[self.nv :], stance),
                                  "relaxed" if relaxed else "solved", solve_time, int(info.iter))
        solve_time = time.perf_counter() - start
        return self.fallback(state, solve_time)

    def _write_problem(self, blocks: _TickBlocks, state: RobotState, tasks: list[Task],
                       stance: tuple[bool, bool], g_map: np.ndarray) -> None:
        """Writes the tick's blocks of the QP (cost, equalities, torque rows, joint-limit
        box; :func:`_problem_buffers` holds the constant ones) through ``blocks``."""
        cfg = self.cfg
        jac, b = stack_tasks(tasks)
        np.matmul(jac.T, jac, out=blocks.hessian_qacc)
        blocks.qacc_diagonal += cfg.w_qacc  # + w_q̈ I
        np.negative(jac.T @ b, out=blocks.gradient_qacc)
        # Equalities: floating base, then stance soles
        mass, bias = state.mass_matrix, state.bias
        blocks.base_mass[...] = mass[:6]
        np.negative(g_map[:6], out=blocks.base_forces)
        np.negative(bias[:6], out=blocks.base_rhs)
        feet = [state.feet[s] for s in (0, 1) if stance[s]]
        for (rows, rhs), foot in zip(blocks.sole_rows, feet, strict=True):
            rows[...] = foot.jacobian
            np.negative(foot.bias_acc, out=rhs)
            rhs -= cfg.contact_kd * foot.velocity
        # Torque rows (those of torque_rows): τ = C x + h_a within ±τ_max
        blocks.torque_mass[...] = mass[6:]
        np.negative(g_map[6:], out=blocks.torque_forces)
        # Joint-limit box on the actuated q̈ (free base and ρ: constant)
        horizon = cfg.limit_horizon
        box = blocks.limit_box
        np.subtract(self._joint_limits(), state.qpos[7:], out=box)
        box -= state.qvel[6:] * horizon
        box *= 2.0
        box /= horizon**2

    def fallback(self, state: RobotState, solve_time: float = 0.0) -> QpSolution:
        """The last good command, else joint damping τ = −K_D q̇ (clipped)."""
        if self.last_good is not None:
            torque, status = self.last_good.copy(), "last_good"
        else:
            torque, status = -constants.KD * state.qvel[6:], "damping"
        torque = np.clip(np.nan_to_num(torque), -constants.EFFORT_LIMITS,
                         constants.EFFORT_LIMITS)
        return QpSolution(torque, np.zeros(self.nv), np.zeros((2, 4, 3)), status, solve_time, 0)

    def _forces(self, rho: np.ndarray, stance: tuple[bool, bool]) -> np.ndarray:
        """Corner forces f = B ρ_i, shape (2, 4, 3) [N] (zeros on a swing foot), from the
        solution's ρ, shape (16 · #stance,)."""
        per_corner = (rho.reshape(-1, 4) @ self.basis.T).reshape(-1, 4, 3)
        if stance[0] and stance[1]:
            return per_corner
        forces = np.zeros((2, 4, 3))
        forces[stance.index(True)] = per_corner[0]
        return forces
