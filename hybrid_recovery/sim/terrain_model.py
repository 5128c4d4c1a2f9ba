"""A terrain's geoms in a robot's ``MjSpec``, and a start state seated on it.

:func:`add_terrain` turns the flat floor of :func:`hybrid_recovery.robot.mjcf.load_spec`
into a :class:`~hybrid_recovery.sim.terrain.Terrain`: a slope tilts the floor plane; rough
ground adds a height field, a step a box, both with the floor's contact settings (ground
geoms: ``contype 0, conaffinity 1``). :func:`seat_on_terrain` places a start state settled
on flat ground onto the terrain without penetrating it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.robot.mjcf import FLOOR_NAME
from hybrid_recovery.sim.initial_states import quat_mul, robot_geoms, seat_single
from hybrid_recovery.sim.terrain import (
    FIELD_RADIUS,
    Terrain,
    highest_ground,
    rough_heights,
    slope_normal,
)

TERRAIN_GEOM = "terrain"
"""Name of the rough field's or the step's geom (and of the height field)."""
_FIELD_BASE = 0.05
"""Thickness of the height field's base below z = 0 [m]."""


def slope_quat(terrain: Terrain) -> np.ndarray:
    """The rotation (w, x, y, z) taking +z to the slope's normal: θ about the horizontal
    axis (sin ψ, −cos ψ, 0); the identity for any other terrain."""
    if terrain.kind != "slope":
        return np.array([1.0, 0.0, 0.0, 0.0])
    half, psi = np.radians(terrain.slope) / 2, np.radians(terrain.heading)
    return np.array([np.cos(half), np.sin(half) * np.sin(psi), -np.sin(half) * np.cos(psi), 0.0])


def add_terrain(spec: mujoco.MjSpec, terrain: Terrain) -> None:
    """Builds ``terrain`` into ``spec`` in place (nothing for flat ground).

    Raises:
        ValueError: ``spec`` has no floor geom named ``floor``.
    """
    floor = spec.geom(FLOOR_NAME)
    if floor is None:
        raise ValueError(f"terrain needs the spec's ground plane '{FLOOR_NAME}'")
    if terrain.is_flat:
        return
    if terrain.kind == "slope":
        floor.quat = slope_quat(terrain)
        return
    geom = spec.worldbody.add_geom(name=TERRAIN_GEOM, contype=0, conaffinity=1,
                                   condim=floor.condim, friction=floor.friction,
                                   solref=floor.solref, solimp=floor.solimp,
                                   rgba=[0.45, 0.42, 0.38, 1.0])
    if terrain.kind == "rough":
        heights = rough_heights(terrain)
        field = spec.add_hfield(name=TERRAIN_GEOM, nrow=heights.shape[0], ncol=heights.shape[1],
                                size=[FIELD_RADIUS, FIELD_RADIUS, terrain.height, _FIELD_BASE])
        field.userdata = (heights / terrain.height).ravel().tolist()
        geom.type = mujoco.mjtGeom.mjGEOM_HFIELD
        geom.hfieldname = TERRAIN_GEOM
    else:
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [FIELD_RADIUS, FIELD_RADIUS, terrain.height / 2]
        geom.pos = [FIELD_RADIUS, 0.0, terrain.height / 2]


def seat_on_terrain(model: mujoco.MjModel, data: mujoco.MjData, terrain: Terrain,
                    clearance: float = 0.005) -> None:
    """Places the state in ``data`` (settled on flat ground) onto ``terrain``, its lowest
    collision geom ``clearance`` [m] off the ground.

    On a slope the whole robot is first turned with the plane about the origin, so that a
    pose lying or standing on flat ground lies or stands on the slope; then it is moved
    along z until its geoms' least distance to the plane is ``clearance`` (exact). On rough
    ground and steps it is moved along z until its lowest geom is ``clearance`` above the
    highest ground within each geom's bounding radius (no penetration; the start may
    hover by up to the terrain's height). Flat ground:
    :func:`~hybrid_recovery.sim.initial_states.seat_single`.
    """
    if terrain.is_flat:
        seat_single(model, data, clearance)
        return
    geoms = robot_geoms(model)
    if terrain.kind == "slope":
        quat = slope_quat(terrain)
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, quat)
        data.qpos[:3] = rot.reshape(3, 3) @ data.qpos[:3]
        data.qpos[3:7] = quat_mul(quat, data.qpos[3:7])
        mujoco.mj_kinematics(model, data)
        normal = slope_normal(terrain)
        distance = data.geom_xpos[geoms] @ normal - _extent(model, data, geoms, normal)
        data.qpos[2] += (clearance - distance.min()) / normal[2]
        return
    mujoco.mj_kinematics(model, data)
    low = data.geom_xpos[geoms, 2] - _extent(model, data, geoms, np.array([0.0, 0.0, 1.0]))
    ground = highest_ground(terrain, data.geom_xpos[geoms, :2], model.geom_rbound[geoms])
    data.qpos[2] += clearance - (low - ground).min()


def _extent(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray,
            direction: np.ndarray) -> np.ndarray:
    """How far each geom reaches from its centre along −``direction`` (unit) [m], (G,):
    exact for boxes, capsules and spheres, the bounding sphere for other shapes."""
    axes = data.geom_xmat[geoms].reshape(-1, 3, 3)  # columns: the geom's axes in the world
    along = np.einsum("gij,i->gj", axes, direction)  # the axes' components along direction
    size, kind = model.geom_size[geoms], model.geom_type[geoms]
    box = np.sum(np.abs(along) * size, -1)
    capsule = np.abs(along[:, 2]) * size[:, 1] + size[:, 0]
    return np.select([kind == mujoco.mjtGeom.mjGEOM_BOX, kind == mujoco.mjtGeom.mjGEOM_CAPSULE,
                      kind == mujoco.mjtGeom.mjGEOM_SPHERE], [box, capsule, size[:, 0]],
                     model.geom_rbound[geoms])


STEP_GEOM = "terrain_step"
"""The step's box in a scene with terrain slots (:func:`add_terrain_slots`)."""
PARKED = -2.0
"""Height below the floor at which a slot not in use waits [m]."""


def rough_slot_name(k: int) -> str:
    """Name of the k-th rough field's geom (and height field) of :func:`add_terrain_slots`."""
    return f"terrain_rough_{k}"


def add_terrain_slots(spec: mujoco.MjSpec, rough: tuple[Terrain, ...],
                      step_height: float) -> None:
    """Adds one height field per terrain of ``rough`` and a step box of ``step_height``
    [m], all parked :data:`PARKED` m below the floor, for a batch whose simulations each
    raise their own (``geom_pos``) and tilt the floor (``geom_quat``): the same geoms as
    :func:`add_terrain` builds, once raised (a step of h: the box's centre at
    (R, 0, h − ``step_height``/2))."""
    floor = spec.geom(FLOOR_NAME)
    contact = {"contype": 0, "conaffinity": 1, "condim": floor.condim,
               "friction": floor.friction, "solref": floor.solref, "solimp": floor.solimp,
               "rgba": [0.45, 0.42, 0.38, 1.0]}
    for k, terrain in enumerate(rough):
        heights = rough_heights(terrain)
        field = spec.add_hfield(name=rough_slot_name(k), nrow=heights.shape[0],
                                ncol=heights.shape[1],
                                size=[FIELD_RADIUS, FIELD_RADIUS, terrain.height, _FIELD_BASE])
        field.userdata = (heights / terrain.height).ravel().tolist()
        spec.worldbody.add_geom(name=rough_slot_name(k), type=mujoco.mjtGeom.mjGEOM_HFIELD,
                                hfieldname=rough_slot_name(k), pos=[0.0, 0.0, PARKED],
                                **contact)
    spec.worldbody.add_geom(name=STEP_GEOM, type=mujoco.mjtGeom.mjGEOM_BOX,
                            size=[FIELD_RADIUS, FIELD_RADIUS, step_height / 2],
                            pos=[FIELD_RADIUS, 0.0, PARKED - step_height], **contact)
