"""The project's H1-2 MJCF against the manufacturer's: masses, inertias, frames, joints, FK.

Both files are compiled directly with ``mujoco.MjModel.from_xml_path`` (not through
``load_mjmodel``), so the comparison does not depend on the project's loader. Tests that
need the reference skip when ``../shared/reference/unitree_h1_2`` is absent.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import H1_2_MJCF

REFERENCE_DIR = Path(__file__).parents[1].parent / "shared" / "reference" / "unitree_h1_2"
REFERENCE_MJCF = REFERENCE_DIR / "h1_2_handless.xml"

FK_TOLERANCE = 1e-3
"""Forward-kinematics tolerance [m]."""

FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
HANDS = ("left_wrist_yaw_link", "right_wrist_yaw_link")


@pytest.fixture(scope="module")
def ours() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(H1_2_MJCF))


@pytest.fixture(scope="module")
def reference() -> mujoco.MjModel:
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    return mujoco.MjModel.from_xml_path(str(REFERENCE_MJCF))


def _robot_bodies(model: mujoco.MjModel) -> list[str]:
    return [model.body(i).name for i in range(1, model.nbody)]


def _rotation(quat: np.ndarray) -> np.ndarray:
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, quat)
    return mat.reshape(3, 3)


def _inertia_tensor(model: mujoco.MjModel, body: int) -> np.ndarray:
    """I = R diag(I_principal) Rᵀ about the body CoM, in body axes [kg·m²]."""
    rot = _rotation(model.body_iquat[body])
    return rot @ np.diag(model.body_inertia[body]) @ rot.T


def _hinge_names(model: mujoco.MjModel) -> list[str]:
    return [
        model.joint(j).name
        for j in range(model.njnt)
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE
    ]


def _map_qpos(src: mujoco.MjModel, dst: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Copies a configuration between models joint by joint (by name)."""
    out = dst.qpos0.copy()
    for j in range(src.njnt):
        name = src.joint(j).name
        width = 7 if src.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE else 1
        a, b = src.jnt_qposadr[j], dst.jnt_qposadr[dst.joint(name).id]
        out[b : b + width] = qpos[a : a + width]
    return out


# --- our model on its own ---------------------------------------------------------------


def test_joint_order_is_motor_order(ours):
    assert ours.njnt == 1 + constants.NUM_JOINTS
    assert ours.joint(0).name == "floating_base_joint"
    assert ours.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert tuple(_hinge_names(ours)) == constants.JOINT_NAMES


def test_total_mass_own(ours):
    assert ours.body_subtreemass[0] == pytest.approx(constants.TOTAL_MASS, abs=1e-9)


def test_primitive_geoms_collide_with_floor_only(ours):
    primitives = {
        int(mujoco.mjtGeom.mjGEOM_SPHERE),
        int(mujoco.mjtGeom.mjGEOM_CAPSULE),
        int(mujoco.mjtGeom.mjGEOM_BOX),
    }
    assert ours.nmesh == 0 and ours.nu == 0
    for g in range(ours.ngeom):
        assert ours.geom_type[g] in primitives, ours.geom(g).name
        assert ours.geom(g).name, f"geom {g} has no name"
        if ours.geom_contype[g]:
            assert (ours.geom_contype[g], ours.geom_conaffinity[g]) == (1, 0)
            assert ours.geom_condim[g] == 3


@pytest.mark.parametrize(
    "site, body",
    [("imu", "torso_link"), ("head", "torso_link")]
    + [
        (f"{s}_foot{c}", f"{s}_ankle_roll_link")
        for s in ("left", "right")
        for c in ("", "_fl", "_fr", "_rl", "_rr")
    ]
    + [
        (f"{s}_{p}", b)
        for s in ("left", "right")
        for p, b in (
            ("hand", f"{s}_wrist_yaw_link"),
            ("elbow", f"{s}_elbow_link"),
            ("knee", f"{s}_knee_link"),
        )
    ],
)
def test_sites(ours, site, body):
    assert ours.body(ours.site(site).bodyid[0]).name == body


def test_sole_sites_on_sole_bottom(ours):
    for side in ("left", "right"):
        sole = ours.geom(f"{side}_foot_sole")
        bottom = sole.pos[2] - sole.size[2]
        corners = np.array([ours.site(f"{side}_foot_{c}").pos for c in ("fl", "fr", "rl", "rr")])
        np.testing.assert_allclose(corners[:, 2], bottom, atol=1e-9)
        np.testing.assert_allclose(
            np.abs(corners[:, :2] - sole.pos[:2]), np.tile(sole.size[:2], (4, 1)), atol=1e-9
        )
        np.testing.assert_allclose(ours.site(f"{side}_foot").pos, [*sole.pos[:2], bottom])
        assert 0.22 <= 2 * sole.size[0] <= 0.26


# --- against the manufacturer's model ---------------------------------------------------


def test_same_kinematic_tree(ours, reference):
    assert _robot_bodies(ours) == _robot_bodies(reference)
    for name in _robot_bodies(ours):
        parent = ours.body(ours.body(name).parentid[0]).name
        assert parent == reference.body(reference.body(name).parentid[0]).name


def test_total_mass_reference(ours, reference):
    assert reference.body_subtreemass[0] == pytest.approx(constants.TOTAL_MASS, abs=1e-9)
    assert ours.body_subtreemass[0] == pytest.approx(reference.body_subtreemass[0], abs=1e-9)


def test_body_inertials(ours, reference):
    for name in _robot_bodies(ours):
        a, b = ours.body(name).id, reference.body(name).id
        assert ours.body_mass[a] == pytest.approx(reference.body_mass[b], rel=1e-12), name
        np.testing.assert_allclose(
            ours.body_ipos[a], reference.body_ipos[b], atol=1e-12, err_msg=name
        )
        np.testing.assert_allclose(
            _inertia_tensor(ours, a),
            _inertia_tensor(reference, b),
            rtol=1e-9,
            atol=1e-12,
            err_msg=name,
        )


def test_body_frames(ours, reference):
    for name in _robot_bodies(ours)[1:]:  # the root's pos is only its initial state
        a, b = ours.body(name).id, reference.body(name).id
        np.testing.assert_allclose(
            ours.body_pos[a], reference.body_pos[b], atol=1e-12, err_msg=name
        )
        np.testing.assert_allclose(
            _rotation(ours.body_quat[a]),
            _rotation(reference.body_quat[b]),
            atol=1e-12,
            err_msg=name,
        )


def test_joints(ours, reference):
    assert _hinge_names(reference) == _hinge_names(ours)
    for i, name in enumerate(constants.JOINT_NAMES):
        a, b = ours.joint(name).id, reference.joint(name).id
        assert ours.jnt_bodyid[a] == ours.body(reference.body(reference.jnt_bodyid[b]).name).id
        np.testing.assert_allclose(ours.jnt_axis[a], reference.jnt_axis[b], err_msg=name)
        np.testing.assert_allclose(ours.jnt_pos[a], reference.jnt_pos[b], err_msg=name)
        np.testing.assert_allclose(ours.jnt_range[a], reference.jnt_range[b], err_msg=name)
        np.testing.assert_allclose(
            ours.jnt_actfrcrange[a], reference.jnt_actfrcrange[b], err_msg=name
        )
        assert ours.jnt_limited[a] and ours.jnt_actfrclimited[a], name
        assert ours.jnt_actfrcrange[a, 1] == constants.EFFORT_LIMITS[i], name


def test_forward_kinematics(ours, reference):
    """Feet, hands and a head point agree within 1 mm at 20 random configurations."""
    rng = np.random.default_rng(0)
    head = ours.site("head").pos  # a point fixed on torso_link, in its frame
    data_ours, data_ref = mujoco.MjData(ours), mujoco.MjData(reference)
    for _ in range(20):
        qpos = ours.qpos0.copy()
        qpos[:3] = rng.uniform(-1.0, 1.0, 3)
        quat = rng.normal(size=4)
        qpos[3:7] = quat / np.linalg.norm(quat)
        qpos[7:] = rng.uniform(ours.jnt_range[1:, 0], ours.jnt_range[1:, 1])
        data_ours.qpos[:] = qpos
        data_ref.qpos[:] = _map_qpos(ours, reference, qpos)
        mujoco.mj_kinematics(ours, data_ours)
        mujoco.mj_kinematics(reference, data_ref)
        for body in FEET + HANDS:
            np.testing.assert_allclose(
                data_ours.body(body).xpos, data_ref.body(body).xpos, atol=FK_TOLERANCE, err_msg=body
            )
        points = [
            d.body("torso_link").xpos + d.body("torso_link").xmat.reshape(3, 3) @ head
            for d in (data_ours, data_ref)
        ]
        np.testing.assert_allclose(points[0], points[1], atol=FK_TOLERANCE, err_msg="head")
