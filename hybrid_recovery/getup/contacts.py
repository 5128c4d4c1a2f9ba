"""Named floor contacts of the H1-2, bound to body names (any H1-2 model with these bodies).

A floor contact is a set of points fixed on one body. Point contacts of a round part
(knee, hand ball, elbow, head, hip) are sphere centres c with a radius r: the contact
lies r below the centre, p = o + R c − r ẑ. A capsule (thigh, shin, shoulder, upper arm,
forearm, the hip motors under the pelvis) is its two axis end points with its radius: a
line contact when it lies flat, its lower end when tipped. Flat parts (soles, pelvis,
back) are their box corners with r = 0. In a configuration, a contact's *active* points
are those within ``ACTIVE_BAND`` of its lowest point (a flat sole: four corners; a tipped
sole: an edge).

Geometry values are the project's collision primitives (``models/h1_2/h1_2.xml``) [m],
in each body's frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

ACTIVE_BAND = 0.01
"""Points within this height of a contact's lowest point bear load [m]."""


@dataclass(frozen=True)
class FloorContact:
    """Points of one body that may touch the floor.

    Attributes:
        name: Contact name, e.g. ``"left_knee"``.
        body: Body the points are fixed on.
        points: Sphere centres or corners c in the body frame, shape (k, 3) [m].
        radius: Sphere radius r (0 for corners) [m].
    """

    name: str
    body: str
    points: tuple[tuple[float, float, float], ...]
    radius: float = 0.0


def _mirror(contact: FloorContact) -> FloorContact:
    return FloorContact(contact.name.replace("left_", "right_"),
                        contact.body.replace("left_", "right_"),
                        tuple((x, -y, z) for x, y, z in contact.points), contact.radius)


_SOLE_X, _SOLE_Y, _SOLE_Z = (0.17, -0.085), 0.0425, -0.045
_LEFT = (
    FloorContact("left_foot", "left_ankle_roll_link",
                 tuple((x, y, _SOLE_Z) for x in _SOLE_X for y in (_SOLE_Y, -_SOLE_Y))),
    FloorContact("left_toes", "left_ankle_roll_link",
                 tuple((_SOLE_X[0], y, _SOLE_Z) for y in (_SOLE_Y, -_SOLE_Y))),
    FloorContact("left_heel", "left_ankle_roll_link",
                 tuple((_SOLE_X[1], y, _SOLE_Z) for y in (_SOLE_Y, -_SOLE_Y))),
    FloorContact("left_knee", "left_knee_link", ((0.0, 0.0, 0.0),), 0.05),
    FloorContact("left_hip", "left_hip_pitch_link", ((0.0, 0.0, 0.0),), 0.065),
    FloorContact("left_elbow", "left_elbow_link", ((0.0, -0.0329, 0.0),), 0.045),
    FloorContact("left_hand", "left_wrist_yaw_link", ((0.025, 0.0, 0.0),), 0.045),
    FloorContact("left_thigh", "left_hip_roll_link", ((0.005, 0.0, -0.07), (0.01, 0.0, -0.33)),
                 0.055),
    FloorContact("left_shin", "left_knee_link", ((0.003, 0.0, -0.07), (0.0, 0.0, -0.3)), 0.045),
    FloorContact("left_shoulder", "left_shoulder_pitch_link", ((0.0, 0.0, 0.0), (0.0, 0.062, 0.0)),
                 0.045),
    FloorContact("left_upper_arm", "left_shoulder_yaw_link",
                 ((0.003, 0.0, 0.09), (0.006, 0.0, -0.16)), 0.045),
    FloorContact("left_forearm", "left_wrist_roll_link", ((-0.08, 0.0, 0.0), (0.09, 0.0, 0.0)),
                 0.035),
)

FLOOR_CONTACTS: dict[str, FloorContact] = {
    c.name: c for c in (
        *_LEFT, *(_mirror(c) for c in _LEFT),
        FloorContact("pelvis", "pelvis",
                     tuple((x, y, -0.085) for x in (0.07, -0.07) for y in (0.15, -0.15))),
        FloorContact("hip_motors", "pelvis", ((0.0, 0.1, -0.15), (0.0, -0.1, -0.15)), 0.06),
        FloorContact("back", "torso_link",
                     tuple((-0.073, y, z) for y in (0.11, -0.11) for z in (0.0, 0.475))),
        FloorContact("chest", "torso_link",
                     tuple((0.073, y, z) for y in (0.11, -0.11) for z in (0.0, 0.475))),
        FloorContact("head", "torso_link", ((0.045, 0.0, 0.675),), 0.085),
    )
}
"""Every named floor contact, by name."""


def check_contact_names(names: tuple[str, ...] | list[str]) -> None:
    """Raises ValueError naming the first unknown contact, or on an empty or repeated set."""
    if len(names) == 0:
        raise ValueError("contact set is empty: name at least one contact of "
                         f"{sorted(FLOOR_CONTACTS)}")
    for name in names:
        if name not in FLOOR_CONTACTS:
            raise ValueError(f"unknown contact '{name}': use one of {sorted(FLOOR_CONTACTS)}")
    if len(set(names)) != len(names):
        raise ValueError(f"contact set names a contact twice: {list(names)}")


def contact_points_world(contact: FloorContact, origin: np.ndarray,
                         rotation: np.ndarray) -> np.ndarray:
    """World positions p = o + R c − r ẑ of all of a contact's points.

    Args:
        contact: The contact.
        origin: Body origin o in the world, shape (3,) [m].
        rotation: Body orientation R (body → world), shape (3, 3).

    Returns:
        Points, shape (k, 3) [m].
    """
    local = np.asarray(contact.points, dtype=float)
    return origin + local @ rotation.T - np.array([0.0, 0.0, contact.radius])


def contact_points_in(model: mujoco.MjModel, data: mujoco.MjData,
                      contact: FloorContact) -> np.ndarray:
    """:func:`contact_points_world` of ``contact`` at its body's pose in ``data`` (xpos,
    xmat, as the last kinematics left them), shape (k, 3) [m]."""
    body = model.body(contact.body).id
    return contact_points_world(contact, data.xpos[body], data.xmat[body].reshape(3, 3))


def active_points(points: np.ndarray, band: float = ACTIVE_BAND) -> np.ndarray:
    """Mask of the points within ``band`` of the lowest one, shape (k,)."""
    return points[:, 2] <= points[:, 2].min() + band
