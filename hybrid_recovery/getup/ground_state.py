"""Which ground state the robot is in: upright, sitting, supine, prone, knee-chest, side.

Read from the torso's axes in the world (x forward out of the chest, y to the left, z up
the spine), the pelvis and CoM heights and the bodies touching the floor as the named
contacts read them (:func:`hybrid_recovery.getup.contact_map.floor_bodies`: on the
manufacturer's meshes a thigh touching at the knee is the knee).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from hybrid_recovery.getup.contact_map import floor_bodies
from hybrid_recovery.robot import constants

GROUND_STATES = ("upright", "sitting", "supine", "prone", "knee_chest", "side", "other")
"""Every state :func:`classify` returns."""

SEAT_BODIES = frozenset({constants.PELVIS_BODY, "left_hip_pitch_link", "right_hip_pitch_link",
                         "left_hip_roll_link", "right_hip_roll_link"})
"""Bodies a sitting robot rests on: the pelvis, or the hip links beside and below it (a robot
sitting upright with its legs spread rests on the hip-pitch links, the pelvis clear)."""


@dataclass(frozen=True)
class GroundPose:
    """What the classification reads.

    Attributes:
        chest_z: z component of the torso's forward axis (+1: chest up, −1: chest down).
        left_z: z component of the torso's left axis (±1: lying on a side).
        spine_z: z component of the torso's up axis (+1: torso upright).
        pelvis_height: Pelvis origin height [m].
        com_height: CoM height h_c [m].
        touching: Names of the robot's bodies touching the floor, as the named contacts
            read them.
    """

    chest_z: float
    left_z: float
    spine_z: float
    pelvis_height: float
    com_height: float
    touching: frozenset[str]


def read_ground_pose(model: mujoco.MjModel, data: mujoco.MjData) -> GroundPose:
    """The :class:`GroundPose` of a forwarded ``data``."""
    torso = model.body(constants.TORSO_BODY).id
    pelvis = model.body(constants.PELVIS_BODY).id
    rot = data.xmat[torso].reshape(3, 3)
    return GroundPose(float(rot[2, 0]), float(rot[2, 1]), float(rot[2, 2]),
                      float(data.xpos[pelvis, 2]), float(data.subtree_com[pelvis, 2]),
                      floor_bodies(model, data))


def classify(pose: GroundPose) -> str:
    """One of :data:`GROUND_STATES`.

    * ``upright``: CoM above 0.6 m, spine within 60° of vertical;
    * ``supine``: chest up (chest_z > 0.6); ``prone``: chest down (chest_z < −0.6) with
      the pelvis below 0.3 m; ``knee_chest``: chest down with the pelvis above 0.3 m and
      both knees on the floor;
    * ``sitting``: spine within 60° of vertical, a seat body (:data:`SEAT_BODIES`) on the
      floor and not both knees;
    * ``side``: a torso side axis within 53° of vertical; ``other``: anything else
      (kneeling, squatting, on all fours ...).
    """
    knees = {"left_knee_link", "right_knee_link"} <= pose.touching
    if pose.com_height > 0.6 and pose.spine_z > 0.5:
        return "upright"
    if pose.chest_z > 0.6:
        return "supine"
    if pose.chest_z < -0.6:
        if pose.pelvis_height < 0.3:
            return "prone"
        if knees:
            return "knee_chest"
        return "other"
    if pose.spine_z > 0.5 and pose.touching & SEAT_BODIES and not knees:
        return "sitting"
    if abs(pose.left_z) > 0.6:
        return "side"
    return "other"
