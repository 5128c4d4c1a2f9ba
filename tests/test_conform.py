"""Any H1-2 MJCF behaves as the project's robot: derived sole/IMU sites, floor-only
contacts, implicit integration, rotor inertia on request, mesh geoms seated exactly."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import REFERENCE_MJCF

from hybrid_recovery.control import BalanceController, load_torque_model, run_episode
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.conform import project_armature, sole_site_names
from hybrid_recovery.robot.mjcf import H1_2_MJCF, default_qpos, load_mjmodel
from hybrid_recovery.sim.initial_states import seat_single


def _reference() -> str:
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    return str(REFERENCE_MJCF)


@pytest.fixture(scope="module")
def siteless(tmp_path_factory) -> str:
    """The project's model with every site removed, written to a file."""
    spec = mujoco.MjSpec.from_file(str(H1_2_MJCF))
    for site in list(spec.sites):
        spec.delete(site)
    path = tmp_path_factory.mktemp("siteless") / "h1_2_siteless.xml"
    path.write_text(spec.to_xml())
    return str(path)


def test_derived_sole_and_imu_sites_are_the_project_sites(siteless):
    """From the sole boxes alone, the derived sole centre and corners are the project's
    hand-placed sites exactly; the IMU sits at the torso link's origin."""
    own, derived = load_mjmodel(), load_mjmodel(siteless)
    for name in sole_site_names():
        assert derived.site(name).bodyid == own.site(name).bodyid
        np.testing.assert_allclose(derived.site(name).pos, own.site(name).pos, atol=1e-9)
    imu = derived.site("imu")
    assert derived.body(int(imu.bodyid[0])).name == constants.TORSO_BODY
    np.testing.assert_array_equal(imu.pos, [0.0, 0.0, 0.0])


def test_qp_stands_on_a_model_without_the_project_sites(siteless):
    model = load_torque_model(siteless)
    result = run_episode(model, BalanceController(), 1.0)
    assert result.standing


def test_a_foot_without_collision_geometry_is_refused(tmp_path):
    spec = mujoco.MjSpec.from_file(str(H1_2_MJCF))
    for site in list(spec.sites):
        spec.delete(site)
    for geom in list(spec.geoms):
        if geom.name == "left_foot_sole":
            spec.delete(geom)
    path = tmp_path / "no_sole.xml"
    path.write_text(spec.to_xml())
    with pytest.raises(ValueError) as info:
        load_mjmodel(path)
    assert str(info.value) == ("body 'left_ankle_roll_link' has no collision geom to derive "
                               "sole sites from")


def test_reference_conforms():
    """Implicit integration, floor-only contacts, the soles on the mesh feet's bottom."""
    model = load_mjmodel(_reference(), timestep=0.001)
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    floor = model.geom("floor").id
    assert (model.geom_contype[floor], model.geom_conaffinity[floor]) == (0, 1)
    robot = np.flatnonzero(model.geom_bodyid > 0)
    colliding = robot[(model.geom_contype[robot] | model.geom_conaffinity[robot]) > 0]
    assert len(colliding) > 20
    assert np.all(model.geom_contype[colliding] == 1)
    assert np.all(model.geom_conaffinity[colliding] == 0)
    assert np.all(model.dof_armature == 0.0)  # the file has none...
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    seat_single(model, data, clearance=0.0)
    mujoco.mj_forward(model, data)
    for name in sole_site_names():  # the soles flat on the floor in the default pose
        assert abs(data.site(name).xpos[2]) < 2e-3


def test_rotor_inertia_gives_the_project_armature():
    model = load_mjmodel(_reference(), rotor_inertia=True)
    for name, armature in zip(constants.JOINT_NAMES, project_armature(), strict=True):
        assert model.dof_armature[model.jnt_dofadr[model.joint(name).id]] == armature
    own = load_mjmodel()
    np.testing.assert_array_equal(own.dof_armature[6:], project_armature())


def test_mesh_geoms_are_seated_by_their_vertices():
    """Seated 1 mm into the floor, the deepest mesh contact is 1 mm deep (the bounding
    sphere left the robot 10 cm in the air)."""
    model = load_mjmodel(_reference(), timestep=0.001)
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    data.qpos[2] += 0.3
    seat_single(model, data, clearance=-1e-3)
    mujoco.mj_forward(model, data)
    assert data.ncon > 0
    dist = np.array([c.dist for c in data.contact[:data.ncon]])
    assert abs(dist.min() + 1e-3) < 1e-6
