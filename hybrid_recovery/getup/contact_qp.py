"""Torque-level whole-body QP on named floor contacts (hands, knees, toes, elbows ...).

The multi-contact form of :mod:`hybrid_recovery.control.wbc_qp`: the soles' corners are
replaced by the load-bearing points of named floor contacts
(:mod:`hybrid_recovery.getup.contacts`: a hand or knee ball is one point, a toe edge two).
Each point i carries a force f_i = B ρ_i in the inner friction pyramid (B from
:func:`~hybrid_recovery.control.wbc_qp.pyramid_basis`, ρ_i ≥ 0). With J_i the point's
translational Jacobian (3, nv) and G = Σ_i J_iᵀ B, decision variables x = [q̈ (nv); ρ]:

    min  Σ_k w_k ‖J_k q̈ − b_k‖² + w_q̈ ‖q̈‖² + w_f Σ_i ‖B ρ_i − f°_i‖² + w_ρ ‖ρ‖²
    s.t. M_u q̈ − G_u ρ = −h_u                           (floating base, 6 rows)
         J_i q̈ = −J̇_i q̇ − k_c J_i q̇                    (each active point, 3 rows)
         −τ_max ≤ M_a q̈ + h_a − G_a ρ ≤ τ_max           (27 torque rows)
         q̈_lo ≤ q̈_a ≤ q̈_hi                             (joint-limit box)
         0 ≤ ρ ≤ ρ_max

The joint-limit box is the standing QP's, q̈_hi = 2 (q_hi − δ − q − q̇ T)/T², with one
change: it never asks more than stopping within T, q̈_hi ≥ −max(q̇, 0)/T (likewise
q̈_lo). A joint inside its margin is then held, not pushed out: with hands, knees and toes
on the floor a leg is a closed chain that often cannot move a joint away from its limit,
and the push-out made the standing box infeasible there.

f°_i are the reference forces, e.g. the static-feasibility QP's
(:func:`hybrid_recovery.getup.feasibility.static_feasibility`): the distribution is
regularised toward the one that uses the least of the effort limits. M and h = C q̇ + g
are MuJoCo's (with the rotor armature), as in the standing QP; τ = M_a q̈ + h_a − G_a ρ.
A point of a sphere (hand, knee, elbow) is its lowest point at this instant, so the
contact rows let it roll but not slide.

Fallbacks (:attr:`ContactQpSolution.status`), as in the standing QP with one step more:
``"limits_relaxed"`` — the joint-limit box dropped (a closed chain of hands, knees and
toes can leave no motion inside it), torque rows kept; ``"relaxed"`` — torque rows and
joint-limit box dropped, torques clipped; ``"last_good"`` — the last
good torques; ``"damping"`` — τ = −K_D q̇. Torques are always finite and inside ±τ_max.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.checks import NON_NEGATIVE, POSITIVE, Range, check_fields
from hybrid_recovery.control.proxsuite_build import proxsuite
from hybrid_recovery.control.robot_state import RobotState, StateReader
from hybrid_recovery.control.wbc_qp import (
    Task,
    free_bounds,
    pyramid_basis,
    stack_tasks,
    torque_rows,
)
from hybrid_recovery.getup.contacts import (
    FLOOR_CONTACTS,
    active_points,
    check_contact_names,
    contact_points_world,
)
from hybrid_recovery.robot import constants

_BIG = 1e10
_SOLVED = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
_WARM_START = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
_EQUALITY_GUESS = proxsuite.proxqp.InitialGuess.EQUALITY_CONSTRAINED_INITIAL_GUESS


@dataclass(frozen=True)
class ContactQpConfig:
    """Weights, limits and solver settings of :class:`ContactQP`.

    Attributes:
        friction: μ of the friction pyramids.
        effort_scale: Torque rows bound |τ| by effort_scale × the hardware limits τ_max.
        w_qacc: w_q̈, regularisation of q̈ [1/(rad/s²)²].
        w_force: w_f, pull toward the reference forces f° [1/N²].
        w_rho: w_ρ, regularisation of the pyramid coefficients ρ [1/N²].
        contact_kd: k_c, contact velocity damping in the contact rows [1/s].
        max_point_force: ρ_max per pyramid edge [N].
        limit_margin: The joint-limit box keeps this far inside the ranges [rad].
        limit_horizon: T of the joint-limit box [s].
        eps_abs: proxsuite's absolute tolerance.
        max_iter: proxsuite's iteration cap.
    """

    friction: float = 0.7
    effort_scale: float = 1.0
    w_qacc: float = 1e-4
    w_force: float = 1e-4
    w_rho: float = 1e-7
    contact_kd: float = 10.0
    max_point_force: float = 1500.0
    limit_margin: float = 0.02
    limit_horizon: float = 0.1
    eps_abs: float = 1e-6
    max_iter: int = 200

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {
    "friction": POSITIVE, "effort_scale": POSITIVE, "w_qacc": POSITIVE,
    "w_force": NON_NEGATIVE, "w_rho": NON_NEGATIVE, "contact_kd": NON_NEGATIVE,
    "max_point_force": POSITIVE, "limit_margin": NON_NEGATIVE, "limit_horizon": POSITIVE,
    "eps_abs": POSITIVE, "max_iter": (1, True, float("inf"))}
"""Field of :class:`ContactQpConfig` → its range."""


def check_config(config: ContactQpConfig) -> None:
    """Every number of ``config`` finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: e.g. ``ContactQpConfig.friction must be > 0, got 0.0``.
    """
    check_fields(config, RANGES)


@dataclass
class ContactPoints:
    """The load-bearing points of the active contacts at one instant, world frame.

    Attributes:
        names: Contact name of each point, length P.
        positions: p_i, shape (P, 3) [m].
        jacobians: J_i with ṗ_i = J_i q̇ (MuJoCo qvel coordinates), shape (P, 3, nv).
        bias_acc: J̇_i q̇, shape (P, 3) [m/s²].
    """

    names: tuple[str, ...]
    positions: np.ndarray
    jacobians: np.ndarray
    bias_acc: np.ndarray


@dataclass
class ContactQpSolution:
    """One tick's command.

    Attributes:
        torque: τ in motor order, shape (27,) [N·m], finite, inside ±τ_max.
        qacc: q̈ of the solution, shape (nv,); zeros for fallbacks.
        forces: f_i on each point of :attr:`points`, world axes, shape (P, 3) [N]; zeros
            for fallbacks.
        points: The contact points of the tick.
        status: ``"solved"``, ``"limits_relaxed"``, ``"relaxed"``, ``"last_good"`` or
            ``"damping"``.
        iterations: proxsuite iterations (0 for fallbacks).
    """

    torque: np.ndarray
    qacc: np.ndarray
    forces: np.ndarray
    points: ContactPoints
    status: str
    iterations: int


class ContactQP:
    """The QP above on a torque-controlled H1-2 model.

    Args:
        model: The torque-controlled model (:func:`~hybrid_recovery.control.torque_model.
            load_torque_model`), with the project's sole and IMU sites.
        config: Settings; defaults when None.
    """

    def __init__(self, model: mujoco.MjModel, config: ContactQpConfig | None = None) -> None:
        self.model, self.cfg = model, config or ContactQpConfig()
        self.reader = StateReader(model)
        self.nv = model.nv
        self.basis = pyramid_basis(self.cfg.friction)
        self.tau_max = constants.EFFORT_LIMITS * self.cfg.effort_scale
        rng = np.array([model.joint(n).range for n in constants.JOINT_NAMES])
        self.q_lo = rng[:, 0] + self.cfg.limit_margin
        self.q_hi = rng[:, 1] - self.cfg.limit_margin
        self._qps: dict[tuple, proxsuite.proxqp.dense.QP] = {}
        self.last_good: np.ndarray | None = None
        self.solver_report = ""
        """proxsuite's status and residuals of the last tick's solve attempts."""

    def reset(self) -> None:
        """Forgets warm starts and the last good command."""
        self._qps.clear()
        self.last_good = None

    def points(self, contacts: tuple[str, ...]) -> ContactPoints:
        """The load-bearing points of ``contacts`` in the reader's current state (call
        after :meth:`read`): each contact's points within ``ACTIVE_BAND`` of its lowest."""
        m, d = self.model, self.reader.data
        names, pos, jac, bias = [], [], [], []
        for name in contacts:
            contact = FLOOR_CONTACTS[name]
            body = m.body(contact.body).id
            world = contact_points_world(contact, d.xpos[body], d.xmat[body].reshape(3, 3))
            for p in world[active_points(world)]:
                jp, jd = np.zeros((3, self.nv)), np.zeros((3, self.nv))
                mujoco.mj_jac(m, d, jp, None, p, body)
                mujoco.mj_jacDot(m, d, jd, None, p, body)
                names.append(name)
                pos.append(p)
                jac.append(jp)
                bias.append(jd @ d.qvel)
        return ContactPoints(tuple(names), np.array(pos).reshape(-1, 3),
                             np.array(jac).reshape(-1, 3, self.nv),
                             np.array(bias).reshape(-1, 3))

    def read(self, data: mujoco.MjData) -> RobotState:
        """The tick's :class:`RobotState` (M, h, pelvis terms) of ``data``."""
        return self.reader.read(data)

    def solve(self, state: RobotState, contacts: tuple[str, ...], tasks: list[Task],
              reference_forces: np.ndarray | None = None) -> ContactQpSolution:
        """Solves the tick's QP on ``contacts``, with the fallbacks of the module docstring.

        Args:
            state: The tick's state from :meth:`read` (the reader's data is this state).
            contacts: Active named contacts (at least one).
            tasks: Least-squares tasks on q̈.
            reference_forces: f°, one per point of :meth:`points` (P, 3) [N]; None: no pull.

        Returns:
            The :class:`ContactQpSolution`.

        Raises:
            ValueError: no, unknown or repeated contacts; reference forces of the wrong
                shape.
        """
        check_contact_names(contacts)
        cfg, nv = self.cfg, self.nv
        pts = self.points(contacts)
        npt = len(pts.names)
        if reference_forces is not None and np.shape(reference_forces) != (npt, 3):
            raise ValueError(f"reference_forces must have shape ({npt}, 3), "
                             f"got {np.shape(reference_forces)}")
        nf = 4 * npt
        n = nv + nf
        g_map = np.einsum("pdn,dk->npk", pts.jacobians, self.basis).reshape(nv, nf)
        jac, b = stack_tasks(tasks)
        hess = np.zeros((n, n))
        hess[:nv, :nv] = jac.T @ jac + cfg.w_qacc * np.eye(nv)
        grad = np.zeros(n)
        grad[:nv] = -jac.T @ b
        block = cfg.w_force * self.basis.T @ self.basis + cfg.w_rho * np.eye(4)
        hess[nv:, nv:] = np.kron(np.eye(npt), block)
        if reference_forces is not None:
            grad[nv:] = -cfg.w_force * (np.asarray(reference_forces, float) @ self.basis
                                        ).reshape(-1)
        contact_rows, contact_rhs = _contact_rows(pts, state.qvel, cfg.contact_kd)
        a_eq = np.vstack([np.hstack([state.mass_matrix[:6], -g_map[:6]]),
                          np.hstack([contact_rows, np.zeros((len(contact_rhs), nf))])])
        b_eq = np.concatenate([-state.bias[:6], contact_rhs])
        c_in, h_a, lo, hi = torque_rows(state, g_map, self.tau_max)
        free_lo, free_hi = free_bounds(nv, nf, cfg.max_point_force)
        box_lo, box_hi = free_lo.copy(), free_hi.copy()
        horizon = cfg.limit_horizon
        q, qd = state.qpos[7:], state.qvel[6:]
        box_lo[6:nv] = np.minimum(2.0 * (self.q_lo - q - qd * horizon) / horizon**2,
                                  np.maximum(-qd, 0.0) / horizon)
        box_hi[6:nv] = np.maximum(2.0 * (self.q_hi - q - qd * horizon) / horizon**2,
                                  -np.maximum(qd, 0.0) / horizon)
        if not all(np.isfinite(a).all() for a in (hess, grad, a_eq, b_eq, c_in, lo, hi,
                                                  box_lo, box_hi)):
            return self.fallback(state, pts)
        free_rows = (np.full(nv - 6, -_BIG), np.full(nv - 6, _BIG))
        levels = (("solved", (lo, hi, box_lo, box_hi)),
                  ("limits_relaxed", (lo, hi, free_lo, free_hi)),
                  ("relaxed", (*free_rows, free_lo, free_hi)))
        reports = []
        for status, bounds in levels:
            key = (pts.names, status)
            fresh = key not in self._qps
            if fresh:
                self._qps[key] = self._new_qp(n, len(b_eq))
            qp = self._qps[key]
            (qp.init if fresh else qp.update)(hess, grad, a_eq, b_eq, c_in, *bounds)
            qp.solve()
            qp.settings.initial_guess = _WARM_START
            x = np.asarray(qp.results.x)
            info = qp.results.info
            reports.append(f"{status}: {info.status.name}, {info.iter} iterations, primal "
                           f"residual {info.pri_res:.2e}, dual residual {info.dua_res:.2e}")
            self.solver_report = "; ".join(reports)
            if info.status != _SOLVED or not np.isfinite(x).all():
                del self._qps[key]  # a failed solve spoils the warm start
                continue
            torque = np.clip(c_in @ x + h_a, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
            self.last_good = torque.copy()
            forces = x[nv:].reshape(npt, 4) @ self.basis.T
            return ContactQpSolution(torque, x[:nv].copy(), forces, pts, status,
                                     int(info.iter))
        return self.fallback(state, pts)

    def _new_qp(self, n: int, n_eq: int) -> proxsuite.proxqp.dense.QP:
        qp = proxsuite.proxqp.dense.QP(n, n_eq, self.nv - 6, True)
        qp.settings.initial_guess = _EQUALITY_GUESS  # warm start only after the first solve
        qp.settings.eps_abs = self.cfg.eps_abs
        qp.settings.eps_rel = 0.0
        qp.settings.max_iter = self.cfg.max_iter
        qp.settings.max_iter_in = self.cfg.max_iter
        qp.settings.verbose = False
        return qp

    def fallback(self, state: RobotState, points: ContactPoints) -> ContactQpSolution:
        """The last good command, else joint damping τ = −K_D q̇ (clipped)."""
        if self.last_good is not None:
            torque, status = self.last_good.copy(), "last_good"
        else:
            torque, status = -constants.KD * state.qvel[6:], "damping"
        torque = np.clip(np.nan_to_num(torque), -constants.EFFORT_LIMITS,
                         constants.EFFORT_LIMITS)
        return ContactQpSolution(torque, np.zeros(self.nv), np.zeros((len(points.names), 3)),
                                 points, status, 0)


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _contact_rows(points: ContactPoints, qvel: np.ndarray, contact_kd: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Rows W J q̈ = W (−J̇ q̇ − k_c J q̇) of each contact's points, shape (r, nv), (r,).

    The k points of one contact lie on one rigid body: p̈_i = a + α × (p_i − p_1) + …, so
    their 3k rows constrain only r ≤ 6 directions of the body's motion (a toe edge: 5),
    and the 3k rows with their velocity-dependent right-hand sides would be inconsistent
    by O(|ω|² |p_i − p_1|²). W (r, 3k) projects them onto the r directions:
    K = [I, −[p_i − p_1]×] (3k, 6) stacked over i, W = the first r left singular vectors
    of K, transposed.
    """
    rows, rhs = [], []
    names = np.array(points.names)
    for name in dict.fromkeys(points.names):
        idx = np.flatnonzero(names == name)
        jac = points.jacobians[idx].reshape(-1, len(qvel))
        target = (-points.bias_acc[idx] - contact_kd * points.jacobians[idx] @ qvel).reshape(-1)
        if len(idx) > 1:
            offsets = points.positions[idx] - points.positions[idx[0]]
            k = np.vstack([np.hstack([np.eye(3), -_skew(r)]) for r in offsets])
            u, sv, _ = np.linalg.svd(k, full_matrices=False)
            w = u[:, sv > 1e-9 * sv[0]].T
            jac, target = w @ jac, w @ target
        rows.append(jac)
        rhs.append(target)
    return np.vstack(rows), np.concatenate(rhs)
