"""Static feasibility of a configuration on a set of floor contacts (a wrench QP).

Given q and named floor contacts (:mod:`hybrid_recovery.getup.contacts`), finds contact
forces f_i (world axes, one per active point) in linearised friction pyramids
|f_x|, |f_y| ≤ μ f_z, f_z ≥ 0, such that the floating base is held,

    Σ_i f_i = m g ẑ,      Σ_i (p_i − c) × f_i = 0,

and the joint torques of static equilibrium, τ = g_j(q) − Σ_i J_i,jᵀ f_i (g_j the joint
rows of the generalised gravity, J_i the point Jacobians), use the least worst fraction of
the effort limits, ρ = max_j |τ_j| / τ_max,j. A proxsuite QP, then a linear program
(HiGHS; proxsuite stalls on this LP for some contact sets), forces in units of m g:

1. support: min W‖s‖² + ε‖f‖² s.t. cones, [Σ f; Σ (p − c) × f] + s = [m g ẑ; 0]. A slack
   s above tolerance means no contact forces hold the base: the state is reported
   unsupported with its leftover wrench s (force [N], moment about the CoM [N·m]).
2. margin: min ρ s.t. cones, base balance less the leftover s of 1. (feasible by
   construction: the forces of 1. satisfy it), −ρ τ_max ≤ τ ≤ ρ τ_max. Should it fail,
   the forces of 1. are kept (``optimal`` False): their ρ is an upper bound of the
   optimum.

The state is feasible when it is supported and ρ ≤ effort_scale. Joints whose torque
exceeds effort_scale · τ_max at the optimum are reported by name with the excess [N·m].
Nothing returned is NaN: a solver failure is reported as infeasible with its reason.

This is the static check of the "wrench-space feasibility over non-coplanar contact
sets" the paper names as future work (§V).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
from scipy.optimize import linprog

from hybrid_recovery.checks import FINITE, POSITIVE, Range, check_fields
from hybrid_recovery.control.proxsuite_build import proxsuite
from hybrid_recovery.dynamics.conventions import qpos_to_pin
from hybrid_recovery.dynamics.robot_model import GRAVITY, RobotModel
from hybrid_recovery.getup.contacts import (
    FLOOR_CONTACTS,
    active_points,
    check_contact_names,
    contact_points_world,
)
from hybrid_recovery.robot import constants

_REG = 1e-5
_SLACK_WEIGHT = 1e6
_SOLVED = proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED


@dataclass(frozen=True)
class FeasibilityConfig:
    """Settings of the static check.

    Attributes:
        friction: Friction coefficient μ of the linearised pyramids.
        effort_scale: Torque limits are effort_scale × the hardware limits τ_max.
        max_gap: A named contact whose lowest point is higher above the floor is refused
            [m].
        support_tolerance: Largest leftover wrench of a supported state, in units of m g
            (force) and m g · 1 m (moment).
        floor_height: Floor height z_g [m].
    """

    friction: float = 0.7
    effort_scale: float = 1.0
    max_gap: float = 0.03
    support_tolerance: float = 1e-4
    floor_height: float = 0.0

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {"friction": POSITIVE, "effort_scale": POSITIVE, "max_gap": POSITIVE,
                            "support_tolerance": POSITIVE, "floor_height": FINITE}
"""Field of :class:`FeasibilityConfig` → its range."""


def check_config(config: FeasibilityConfig) -> None:
    """Every number of ``config`` finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: e.g. ``FeasibilityConfig.floor_height must be finite, got nan``.
    """
    check_fields(config, RANGES)


@dataclass
class StaticCheck:
    """Result of :func:`static_feasibility`.

    Attributes:
        feasible: Supported and ρ ≤ effort_scale.
        supported: Some contact forces in the cones hold the base.
        worst_ratio: ρ = max_j |τ_j| / τ_max,j at the optimum (hardware limits).
        torques: τ = g_j(q) − Σ J_i,jᵀ f_i, shape (27,) [N·m], motor order.
        points: Active contact points per contact, each (k, 3) [m], world.
        forces: Force on each active point, each (k, 3) [N], world axes.
        leftover_wrench: Wrench the contacts fail to supply (force [N], moment about the
            CoM [N·m]), shape (6,); zero when supported.
        over_limit: Joint name → |τ_j| − effort_scale · τ_max,j [N·m], for joints over it.
        reason: Empty when feasible, else why not.
        optimal: ρ is the optimum (False: the margin QP did not converge and ρ is that of
            the support QP's forces, an upper bound).
    """

    feasible: bool
    supported: bool
    worst_ratio: float
    torques: np.ndarray
    points: dict[str, np.ndarray]
    forces: dict[str, np.ndarray]
    leftover_wrench: np.ndarray
    over_limit: dict[str, float] = field(default_factory=dict)
    reason: str = ""
    optimal: bool = True

    def load_share(self) -> dict[str, float]:
        """Each contact's share of the total vertical force, summing to 1."""
        total = sum(float(f[:, 2].sum()) for f in self.forces.values())
        return {k: float(f[:, 2].sum()) / total if total > 0 else 0.0
                for k, f in self.forces.items()}


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _check_qpos(robot: RobotModel, qpos: np.ndarray) -> np.ndarray:
    arr = np.asarray(qpos, dtype=float)
    if arr.shape != (robot.nq,):
        raise ValueError(f"qpos must have shape ({robot.nq},), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError("qpos contains NaN or inf")
    return arr


def _contact_geometry(robot: RobotModel, q: np.ndarray, names: tuple[str, ...],
                      config: FeasibilityConfig):
    """Active points (world), their joint-column Jacobians and names."""
    model, data = robot.model, robot.data
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    points, jacobians, owners = [], [], []
    for name in names:
        contact = FLOOR_CONTACTS[name]
        frame = model.getFrameId(contact.body, pin.FrameType.BODY)
        if frame >= model.nframes:
            raise ValueError(f"contact '{name}': the model has no body '{contact.body}'")
        pose = data.oMf[frame]
        world = contact_points_world(contact, pose.translation, pose.rotation)
        gap = float(world[:, 2].min()) - config.floor_height
        if gap > config.max_gap:
            raise ValueError(f"contact '{name}' is {gap:.3f} m above the floor "
                             f"(at most {config.max_gap:.3f} m)")
        jac = pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        for p in world[active_points(world)]:
            points.append(p)
            jacobians.append(jac[:3] - _skew(p - pose.translation) @ jac[3:])
            owners.append(name)
    return np.array(points), np.array(jacobians), owners


def _cone_rows(n: int, mu: float) -> np.ndarray:
    """C with C f ≥ 0 ⇔ each f_i in its linearised pyramid, shape (5n, 3n)."""
    block = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, mu], [1.0, 0.0, mu],
                      [0.0, -1.0, mu], [0.0, 1.0, mu]])
    return np.kron(np.eye(n), block)


def _solve(h, g, a, b, c, lo, hi) -> np.ndarray | None:
    qp = proxsuite.proxqp.dense.QP(h.shape[0], a.shape[0], c.shape[0])
    qp.settings.eps_abs = 1e-9
    qp.settings.eps_rel = 0.0
    qp.settings.max_iter = 10_000
    qp.settings.verbose = False
    qp.init(h, g, a, b, c, lo, hi)
    qp.solve()
    x = np.asarray(qp.results.x)
    if qp.results.info.status != _SOLVED or not np.isfinite(x).all():
        return None
    return x


def static_feasibility(robot: RobotModel, qpos: np.ndarray, contacts: tuple[str, ...] | list[str],
                       config: FeasibilityConfig | None = None) -> StaticCheck:
    """Checks that ``qpos`` can be held still on ``contacts`` within the effort limits.

    Args:
        robot: The robot's dynamics (joint order = ``constants.JOINT_NAMES``).
        qpos: MuJoCo configuration, shape (nq,).
        contacts: Names from :data:`FLOOR_CONTACTS`.
        config: Settings; defaults (μ 0.7, 1× limits) when None.

    Returns:
        The :class:`StaticCheck`.

    Raises:
        ValueError: a wrong shape, NaN or inf in qpos, an unknown or repeated contact, a
            contact above the floor by more than ``max_gap``.
    """
    cfg = config or FeasibilityConfig()
    names = tuple(contacts)
    check_contact_names(names)
    qpos = _check_qpos(robot, qpos)
    q = qpos_to_pin(qpos)
    points, jac, owners = _contact_geometry(robot, q, names, cfg)
    gravity = pin.computeGeneralizedGravity(robot.model, robot.data, q)[6:]
    com = pin.centerOfMass(robot.model, robot.data, q)
    weight = robot.mass * GRAVITY
    n = len(points)
    # base balance in units of m g: [Σ φ; Σ (p − c) × φ] = [ẑ; 0]
    base = np.zeros((6, 3 * n))
    for i, p in enumerate(points):
        base[:3, 3 * i:3 * i + 3] = np.eye(3)
        base[3:, 3 * i:3 * i + 3] = _skew(p - com)
    target = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    cones = _cone_rows(n, cfg.friction)
    big = np.full(cones.shape[0], 1e20)
    # τ = g − m g Jᵀ φ, joint rows only
    jt = weight * np.concatenate([j[:, 6:] for j in jac], axis=0).T  # (27, 3n)
    limits = constants.EFFORT_LIMITS

    # 1. support
    nx = 3 * n + 6
    h = np.diag(np.r_[np.full(3 * n, _REG), np.full(6, _SLACK_WEIGHT)])
    x = _solve(h, np.zeros(nx), np.hstack([base, np.eye(6)]), target,
               np.hstack([cones, np.zeros((cones.shape[0], 6))]), np.zeros(len(big)), big)
    if x is None:
        return _failed(points, owners, names, "support QP did not converge")
    slack = x[3 * n:]
    phi = x[:3 * n]
    if np.abs(slack).max() > cfg.support_tolerance:
        torques = gravity - jt @ phi
        leftover = slack * weight
        return _result(False, False, torques, phi * weight, points, owners, names, leftover,
                       cfg, "base unsupported: the contacts leave a wrench of "
                       f"{np.linalg.norm(leftover[:3]):.1f} N and "
                       f"{np.linalg.norm(leftover[3:]):.1f} N·m unbalanced")

    # 2. worst torque-limit ratio (a linear program: x = [φ, ρ])
    scaled = jt / limits[:, None]
    torque_rows = np.vstack([np.hstack([-scaled, -np.ones((27, 1))]),
                             np.hstack([scaled, -np.ones((27, 1))])])
    a_ub = np.vstack([np.hstack([-cones, np.zeros((cones.shape[0], 1))]), torque_rows])
    b_ub = np.r_[np.zeros(cones.shape[0]), -gravity / limits, gravity / limits]
    lp = linprog(np.r_[np.zeros(3 * n), 1.0], A_ub=a_ub, b_ub=b_ub,
                 A_eq=np.hstack([base, np.zeros((6, 1))]), b_eq=target - slack,
                 bounds=[(None, None)] * (3 * n + 1), method="highs")
    optimal = lp.status == 0 and np.isfinite(lp.x).all()
    if optimal:
        phi = lp.x[:3 * n]
    torques = gravity - jt @ phi
    check = _result(True, True, torques, phi * weight, points, owners, names, slack * weight,
                    cfg, "")
    check.optimal = optimal
    return check


def _result(feasible: bool, supported: bool, torques: np.ndarray, forces: np.ndarray,
            points: np.ndarray, owners: list[str], names: tuple[str, ...], leftover: np.ndarray,
            cfg: FeasibilityConfig, reason: str) -> StaticCheck:
    limits = constants.EFFORT_LIMITS
    ratio = np.abs(torques) / limits
    excess = np.abs(torques) - cfg.effort_scale * limits
    over = {constants.JOINT_NAMES[j]: float(excess[j]) for j in np.flatnonzero(excess > 1e-6)}
    if supported and over:
        feasible = False
        reason = (f"over the {cfg.effort_scale:g}× effort limits: " + ", ".join(
            f"{k} by {v:.1f} N·m" for k, v in sorted(over.items(), key=lambda kv: -kv[1])))
    f3 = forces.reshape(-1, 3)
    owner = np.array(owners)
    return StaticCheck(
        feasible=feasible, supported=supported, worst_ratio=float(ratio.max()),
        torques=torques, points={k: points[owner == k] for k in names},
        forces={k: f3[owner == k] for k in names}, leftover_wrench=leftover,
        over_limit=over, reason=reason)


def _failed(points: np.ndarray, owners: list[str], names: tuple[str, ...],
            reason: str) -> StaticCheck:
    owner = np.array(owners)
    return StaticCheck(False, False, float("inf"), np.zeros(constants.NUM_JOINTS),
                       {k: points[owner == k] for k in names},
                       {k: np.zeros((int((owner == k).sum()), 3)) for k in names},
                       np.zeros(6), {}, reason)
