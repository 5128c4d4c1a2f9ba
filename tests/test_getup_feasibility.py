"""Static feasibility on floor contacts: known answers, cross-checks, exact errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.optimize import linprog

from hybrid_recovery.dynamics.robot_model import GRAVITY
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, contact_points_world
from hybrid_recovery.getup.feasibility import FeasibilityConfig, static_feasibility
from hybrid_recovery.robot import constants

FEET = ("left_foot", "right_foot")


def _on_floor(robot, qpos: np.ndarray, contact: str = "left_foot") -> np.ndarray:
    """qpos with the base lowered so that ``contact``'s lowest point is at z = 0."""
    model = robot.mj_model
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    c = FLOOR_CONTACTS[contact]
    body = model.body(c.body).id
    points = contact_points_world(c, data.xpos[body], data.xmat[body].reshape(3, 3))
    out = qpos.copy()
    out[2] -= points[:, 2].min()
    return out


def _crouch(robot, hip: float, knee: float) -> np.ndarray:
    """Upright torso, feet flat: hip pitch −hip, knee, ankle pitch −(knee − hip) [rad]."""
    qpos = np.zeros(robot.nq)
    qpos[2], qpos[3] = 1.0, 1.0
    qpos[7:] = constants.DEFAULT_JOINT_POS
    for side in (0, 6):
        qpos[7 + side + 1], qpos[7 + side + 3], qpos[7 + side + 4] = -hip, knee, hip - knee
    return _on_floor(robot, qpos)


def _standing(robot) -> np.ndarray:
    return _crouch(robot, 0.16, 0.36)


def _all_forces(check) -> tuple[np.ndarray, np.ndarray]:
    points = np.concatenate([check.points[k] for k in check.points])
    forces = np.concatenate([check.forces[k] for k in check.forces])
    return points, forces


def test_standing_forces_carry_the_weight_and_cop_is_under_the_com(robot):
    qpos = _standing(robot)
    check = static_feasibility(robot, qpos, FEET)
    assert check.feasible and check.supported and check.reason == ""
    points, forces = _all_forces(check)
    np.testing.assert_allclose(forces.sum(axis=0), [0.0, 0.0, robot.mass * GRAVITY], atol=1e-6)
    cop = (points[:, :2] * forces[:, 2:3]).sum(axis=0) / forces[:, 2].sum()
    com = robot.balance_state(qpos, np.zeros(robot.nv)).com
    assert np.linalg.norm(cop - com[:2]) < 1e-3
    mu = FeasibilityConfig().friction
    assert (forces[:, 2] >= -1e-9).all()
    assert (np.abs(forces[:, :2]) <= mu * forces[:, 2:3] + 1e-6).all()
    assert np.abs(check.leftover_wrench).max() < 1e-6


@pytest.mark.parametrize("edge", ["heel", "toes"])
def test_com_outside_the_support_is_unsupported(own_model, edge):
    check = static_feasibility(own_model, _standing(own_model),
                               (f"left_{edge}", f"right_{edge}"))
    assert not check.feasible and not check.supported
    assert check.reason.startswith("base unsupported: the contacts leave a wrench of ")
    # the CoM lies off the line through the edge points: a moment of at least 10 N·m
    # (about 1.5 cm of m g lever) stays unbalanced
    assert np.linalg.norm(check.leftover_wrench) > 10.0
    assert np.isfinite(check.torques).all() and np.isfinite(check.worst_ratio)


def test_a_deep_crouch_holds_at_full_limits_but_not_at_half(own_model):
    qpos = _crouch(own_model, 0.7, 2.0)
    full = static_feasibility(own_model, qpos, FEET)
    assert full.feasible and 0.5 < full.worst_ratio < 1.0
    half = static_feasibility(own_model, qpos, FEET, FeasibilityConfig(effort_scale=0.5))
    assert half.supported and not half.feasible
    assert half.worst_ratio == pytest.approx(full.worst_ratio, abs=1e-6)
    assert half.over_limit, "joints over the halved limits must be named"
    for name, excess in half.over_limit.items():
        j = constants.JOINT_NAMES.index(name)
        assert excess == pytest.approx(abs(half.torques[j]) - 0.5 * constants.EFFORT_LIMITS[j])
        assert excess > 0.0
    worst = max(half.over_limit, key=half.over_limit.__getitem__)
    assert half.reason.startswith(f"over the 0.5× effort limits: {worst} by ")


def _mujoco_gravity_and_jacobians(robot, qpos, check):
    model = robot.mj_model
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    jacs = []
    for name, pts in check.points.items():
        body = model.body(FLOOR_CONTACTS[name].body).id
        for p in pts:
            jacp = np.zeros((3, model.nv))
            mujoco.mj_jac(model, data, jacp, None, p, body)
            jacs.append(jacp)
    return data.qfrc_bias.copy(), np.array(jacs)


@pytest.mark.parametrize("pose", ["standing", "crouch"])
def test_torques_are_gravity_minus_contact_forces_in_mujoco_and_rnea(own_model, pose):
    import pinocchio as pin

    from hybrid_recovery.dynamics.conventions import qpos_to_pin

    qpos = _standing(own_model) if pose == "standing" else _crouch(own_model, 0.7, 2.0)
    check = static_feasibility(own_model, qpos, FEET)
    _, forces = _all_forces(check)
    bias, jacs = _mujoco_gravity_and_jacobians(own_model, qpos, check)
    generalised = bias - np.einsum("kiv,ki->v", jacs, forces)
    np.testing.assert_allclose(check.torques, generalised[6:], atol=1e-6)
    # static equilibrium of the floating base in MuJoCo's own coordinates
    np.testing.assert_allclose(generalised[:6], 0.0, atol=1e-6)
    q = qpos_to_pin(qpos)
    rnea = pin.rnea(own_model.model, own_model.data, q, np.zeros(own_model.nv),
                    np.zeros(own_model.nv))
    np.testing.assert_allclose(rnea[6:] - np.einsum("kiv,ki->v", jacs, forces)[6:],
                               check.torques, atol=1e-6)


@pytest.mark.parametrize("hip, knee", [(0.16, 0.36), (0.7, 2.0), (0.9, 1.6)])
def test_worst_ratio_equals_an_independent_linear_program(own_model, hip, knee):
    qpos = _crouch(own_model, hip, knee)
    check = static_feasibility(own_model, qpos, FEET)
    bias, jacs = _mujoco_gravity_and_jacobians(own_model, qpos, check)
    n, mu, limits = len(jacs), 0.7, constants.EFFORT_LIMITS
    # variables [f (3n), ρ]; equilibrium of all 33 rows in MuJoCo coordinates:
    # base rows Σ Jᵀ f = bias_base, joint rows |bias_j − Σ Jᵀ f| ≤ ρ τ_max
    jt = np.concatenate(list(jacs), axis=0).T  # (nv, 3n)
    a_eq = np.hstack([jt[:6], np.zeros((6, 1))])
    cone = np.array([[0, 0, -1], [1, 0, -mu], [-1, 0, -mu], [0, 1, -mu], [0, -1, -mu]], float)
    a_ub = [np.hstack([np.kron(np.eye(n), cone), np.zeros((5 * n, 1))]),
            np.hstack([-jt[6:], -limits[:, None]]), np.hstack([jt[6:], -limits[:, None]])]
    b_ub = np.r_[np.zeros(5 * n), -bias[6:], bias[6:]]
    lp = linprog(np.r_[np.zeros(3 * n), 1.0], A_ub=np.vstack(a_ub), b_ub=b_ub, A_eq=a_eq,
                 b_eq=bias[:6], bounds=[(None, None)] * (3 * n + 1), method="highs")
    assert lp.status == 0
    assert check.worst_ratio == pytest.approx(lp.fun, abs=1e-4)


def test_bad_input_messages(own_model):
    qpos = _standing(own_model)
    cases = [
        (lambda: static_feasibility(own_model, qpos[:-1], FEET),
         "qpos must have shape (34,), got (33,)"),
        (lambda: static_feasibility(own_model, np.where(np.arange(34) == 9, np.nan, qpos), FEET),
         "qpos contains NaN or inf"),
        (lambda: static_feasibility(own_model, qpos, ("left_foot", "left_paw")),
         f"unknown contact 'left_paw': use one of {sorted(FLOOR_CONTACTS)}"),
        (lambda: static_feasibility(own_model, qpos, ()),
         f"contact set is empty: name at least one contact of {sorted(FLOOR_CONTACTS)}"),
        (lambda: static_feasibility(own_model, qpos, ("left_foot", "left_foot")),
         "contact set names a contact twice: ['left_foot', 'left_foot']"),
        (lambda: FeasibilityConfig(friction=0.0),
         "FeasibilityConfig.friction must be > 0, got 0.0"),
        (lambda: FeasibilityConfig(effort_scale=-1.0),
         "FeasibilityConfig.effort_scale must be > 0, got -1.0"),
        (lambda: FeasibilityConfig(floor_height=np.nan),
         "FeasibilityConfig.floor_height must be finite, got nan"),
    ]
    for call, message in cases:
        with pytest.raises(ValueError) as err:
            call()
        assert str(err.value) == message
    with pytest.raises(ValueError, match=r"^contact 'left_hand' is 0\.\d{3} m above the floor "
                                         r"\(at most 0\.030 m\)$"):
        static_feasibility(own_model, qpos, ("left_foot", "right_foot", "left_hand"))
