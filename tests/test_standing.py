"""Loading the H1-2 (floor, PD actuators, errors) and standing under its own PD for 10 s."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import FLOOR_NAME, H1_2_MJCF, default_qpos, load_mjmodel

REFERENCE_MJCF = (
    Path(__file__).parents[1].parent / "shared" / "reference" / "unitree_h1_2" / "h1_2_handless.xml"
)


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return load_mjmodel()


def _standing_data(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    data.ctrl[:] = constants.DEFAULT_JOINT_POS
    mujoco.mj_forward(model, data)
    return data


def _tilt_deg(data: mujoco.MjData, body: str) -> float:
    """Angle between the body's z axis and the world's z axis [deg]."""
    return float(np.degrees(np.arccos(np.clip(data.body(body).xmat[8], -1.0, 1.0))))


def _chain_mjcf(joint_names: list[str]) -> str:
    """A free-floating chain of light bodies, one hinge per name, in the given order."""
    inner = ""
    for name in reversed(joint_names):
        inner = (
            '<body pos="0 0 -0.05">'
            '<inertial pos="0 0 0" mass="0.1" diaginertia="1e-3 1e-3 1e-3"/>'
            f'<joint name="{name}" axis="0 1 0"/>{inner}</body>'
        )
    return (
        '<mujoco><worldbody><body name="pelvis" pos="0 0 1">'
        '<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>'
        f'<freejoint name="floating_base_joint"/>{inner}</body></worldbody></mujoco>'
    )


# --- loading -----------------------------------------------------------------------------


def test_default_path_is_repository_model():
    assert H1_2_MJCF.is_file()
    assert H1_2_MJCF.parts[-3:] == ("models", "h1_2", "h1_2.xml")


def test_floor_and_actuators(model):
    floor = model.geom(FLOOR_NAME)
    assert floor.type[0] == mujoco.mjtGeom.mjGEOM_PLANE
    assert (floor.contype[0], floor.conaffinity[0]) == (0, 1)
    assert model.nu == constants.NUM_JOINTS
    assert model.opt.timestep == 0.005
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    for i, name in enumerate(constants.JOINT_NAMES):
        assert model.joint(model.actuator_trnid[i, 0]).name == name
        assert model.actuator_gainprm[i, 0] == constants.KP[i]
        np.testing.assert_array_equal(
            model.actuator_biasprm[i, :3], [0.0, -constants.KP[i], -constants.KD[i]]
        )
        np.testing.assert_array_equal(
            model.actuator_forcerange[i], [-constants.EFFORT_LIMITS[i], constants.EFFORT_LIMITS[i]]
        )
        assert model.actuator_forcelimited[i] and not model.actuator_ctrllimited[i]


def test_pd_law(model):
    """τ = clip(k_p (q_ref − q) − k_d q̇, ±τ_max) at a random state."""
    rng = np.random.default_rng(1)
    data = _standing_data(model)
    data.qpos[7:] += rng.uniform(-0.3, 0.3, constants.NUM_JOINTS)
    data.qvel[6:] = rng.normal(size=constants.NUM_JOINTS)
    data.ctrl[:] = constants.DEFAULT_JOINT_POS + rng.uniform(-0.5, 0.5, constants.NUM_JOINTS)
    mujoco.mj_forward(model, data)
    tau = constants.KP * (data.ctrl - data.qpos[7:]) - constants.KD * data.qvel[6:]
    expected = np.clip(tau, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
    np.testing.assert_allclose(data.actuator_force, expected, rtol=1e-12, atol=1e-9)


def test_options(model):
    assert load_mjmodel(timestep=0.002).opt.timestep == 0.002
    bare = load_mjmodel(floor=False, actuators=False)
    assert bare.nu == 0 and bare.ngeom == model.ngeom - 1


def test_actuators_follow_constants_not_file_order(tmp_path):
    path = tmp_path / "reversed.xml"
    path.write_text(_chain_mjcf(list(reversed(constants.JOINT_NAMES))))
    model = load_mjmodel(path)
    assert [model.joint(model.actuator_trnid[i, 0]).name for i in range(model.nu)] == list(
        constants.JOINT_NAMES
    )
    qpos = default_qpos(model)
    for i, name in enumerate(constants.JOINT_NAMES):
        assert qpos[model.jnt_qposadr[model.joint(name).id]] == constants.DEFAULT_JOINT_POS[i]


def test_missing_file(tmp_path):
    path = tmp_path / "missing.xml"
    with pytest.raises(FileNotFoundError) as info:
        load_mjmodel(path)
    assert str(info.value) == f"H1-2 MJCF not found: {path}"


def test_missing_joint(tmp_path):
    path = tmp_path / "no_waist.xml"
    path.write_text(_chain_mjcf([n for n in constants.JOINT_NAMES if n != "torso_joint"]))
    with pytest.raises(ValueError) as info:
        load_mjmodel(path)
    assert str(info.value) == f"H1-2 MJCF {path} has no joint named 'torso_joint'"


def test_loads_reference_from_any_directory(tmp_path, monkeypatch):
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    monkeypatch.chdir(tmp_path)  # its meshes are relative to its own directory
    reference = load_mjmodel(REFERENCE_MJCF)
    names = [reference.geom(g).name for g in range(reference.ngeom)]
    assert names.count(FLOOR_NAME) == 1  # the file's own floor, none added
    assert reference.nu == constants.NUM_JOINTS  # its motors replaced by the PD servos
    assert reference.actuator_gaintype[0] == mujoco.mjtGain.mjGAIN_FIXED
    assert reference.actuator_biasprm[0, 1] == -constants.KP[0]


# --- the standing state --------------------------------------------------------------------


def test_default_qpos(model):
    qpos = default_qpos(model)
    np.testing.assert_array_equal(qpos[:7], [0, 0, constants.DEFAULT_BASE_HEIGHT, 1, 0, 0, 0])
    np.testing.assert_array_equal(qpos[7:], constants.DEFAULT_JOINT_POS)


def test_soles_touch_floor_without_penetration(model):
    """At q*, all sole corners lie within 1 mm of z = 0 and no contact penetrates > 1 mm."""
    data = _standing_data(model)
    for side in ("left", "right"):
        for corner in ("fl", "fr", "rl", "rr"):
            assert abs(data.site(f"{side}_foot_{corner}").xpos[2]) < 1e-3
    dist = np.array([data.contact[i].dist for i in range(data.ncon)])
    assert data.ncon > 0 and dist.min() > -1e-3
    floor = model.geom(FLOOR_NAME).id
    touching = {int(g) for c in data.contact[: data.ncon] for g in c.geom if g != floor}
    assert touching == {model.geom("left_foot_sole").id, model.geom("right_foot_sole").id}


def test_stands_10_s_under_pd(model):
    """No controller: ctrl = q*; the pelvis stays within 5 cm and the torso within 10°."""
    data = _standing_data(model)
    z0 = data.qpos[2]
    max_dz = max_tilt = 0.0
    for _ in range(round(10.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        max_dz = max(max_dz, abs(data.qpos[2] - z0))
        max_tilt = max(max_tilt, _tilt_deg(data, constants.TORSO_BODY))
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    assert max_dz < 0.05
    assert max_tilt < 10.0
