"""The named floor contacts read off MuJoCo's contact list: the shapes, the project's
geoms by name, the manufacturer's meshes by where they touch."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import REFERENCE_MJCF

from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import eval_model, start_state
from hybrid_recovery.getup.contact_map import (
    floor_bodies,
    floor_contacts,
    shape_distance,
    touching_bodies,
)
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, FloorContact
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.initial_states import seat_single

POSES = ("standing", "squatting", "kneeling", "sitting", "supine", "prone")


def _rot_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_shape_distance_of_a_sphere_a_capsule_and_a_rectangle():
    origin, eye = np.array([1.0, 2.0, 0.5]), np.eye(3)
    sphere = FloorContact("s", "b", ((0.1, 0.0, 0.0),), 0.05)
    assert shape_distance(sphere, origin, eye, origin + [0.1, 0.0, 0.3]) == pytest.approx(0.25)
    # inside: negative, by the depth
    assert shape_distance(sphere, origin, eye, origin + [0.1, 0.01, 0.0]) == pytest.approx(-0.04)
    capsule = FloorContact("c", "b", ((0.0, 0.0, 0.0), (0.0, 0.0, -0.4)), 0.05)
    # beside its middle: to the axis; beyond an end: to that end
    assert shape_distance(capsule, origin, eye, origin + [0.2, 0.0, -0.2]) == pytest.approx(0.15)
    assert shape_distance(capsule, origin, eye, origin + [0.0, 0.3, -0.8]) == pytest.approx(0.45)
    rectangle = FloorContact("r", "b", tuple((x, y, 0.0) for x in (0.1, -0.1)
                                             for y in (0.05, -0.05)))
    below = origin + [0.03, -0.02, -0.2]
    assert shape_distance(rectangle, origin, eye, below) == pytest.approx(0.2)
    assert shape_distance(rectangle, origin, eye, origin + [0.4, 0.0, 0.0]) == pytest.approx(0.3)
    assert shape_distance(rectangle, origin, eye, origin + [0.4, 0.45, 0.0]) == pytest.approx(0.5)
    # the body's orientation: the rectangle's long side turned onto the world's y
    turned = _rot_z(np.pi / 2)
    for point, distance in (([0.0, 0.4, 0.0], 0.3), ([0.4, 0.0, 0.0], 0.35)):
        assert shape_distance(rectangle, origin, turned, origin + point) == pytest.approx(distance)


def _settled(path: str | None, pose: str, seed: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A start of ``pose`` held by the servos for 0.5 s (resting on the floor)."""
    timestep = 0.005 if path is None else 0.001
    model = eval_model(path, timestep, False, "default", path is not None)
    data = mujoco.MjData(model)
    data.qpos[:] = start_state(Scenario(pose, seed=seed), path, "default", timestep,
                               path is not None)
    seat_single(model, data)
    data.ctrl[:] = data.qpos[model.jnt_qposadr[1:1 + constants.NUM_JOINTS]]
    for _ in range(int(round(0.5 / timestep))):
        mujoco.mj_step(model, data)
    return model, data


@pytest.mark.parametrize("pose", POSES)
def test_on_the_project_model_every_touching_geom_is_its_named_contact(pose):
    for seed in range(2):
        model, data = _settled(None, pose, seed)
        named, unmapped = floor_contacts(model, data)
        assert named and unmapped == ()
        assert floor_bodies(model, data) == touching_bodies(model, data)


def test_the_manufacturer_meshes_are_read_as_the_named_contacts_where_they_touch():
    """Mesh contacts map to the named contact nearest where they touch: the thigh meshes
    at the knee are the knees, the wrist meshes of the handless arms the hands, a thigh
    mesh lying along the floor the thigh; nothing is left unread."""
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    path = str(REFERENCE_MJCF)
    read: dict[str, set[str]] = {}
    for pose in POSES:
        for seed in range(2):
            model, data = _settled(path, pose, seed)
            named, unmapped = floor_contacts(model, data)
            assert named and unmapped == (), (pose, seed)
            read[f"{pose}{seed}"] = set(named)
            assert floor_bodies(model, data) == {FLOOR_CONTACTS[n].body for n in named}
    assert {"left_knee", "right_knee"} <= read["kneeling1"]
    assert {"left_hand", "right_hand", "left_thigh", "right_thigh"} <= read["prone0"]
    touching = touching_bodies(model, data)  # the last: prone, the wrist meshes touch
    assert "left_wrist_pitch_link" in touching and "left_wrist_yaw_link" not in touching
    assert "left_wrist_yaw_link" in floor_bodies(model, data)
