"""The named floor contacts of a MuJoCo state: MuJoCo's robot–floor contacts, by geom.

Every collision geom of the project's H1-2 (``models/h1_2/h1_2.xml``) is one of the
named contacts of :data:`hybrid_recovery.getup.contacts.FLOOR_CONTACTS`, except two that
several named contacts share:

* a sole: ``<side>_toes`` where it touches ahead of the sole's middle (x > 0.0425 m in
  the ankle-roll frame), ``<side>_heel`` behind it, ``<side>_foot`` where both;
* the torso box: ``back`` where it touches behind the torso's mid-plane (x < 0 in the
  torso frame), ``chest`` in front of it.

A geom of another model (the manufacturer's meshes) is read by where it touches: the
named contact, among those on its body and the bodies next to it in the tree, whose
shape lies nearest the contact point, if within ``MESH_TOLERANCE`` (the thigh mesh
touching at the knee is ``<side>_knee``; the wrist mesh of a handless arm is
``<side>_hand``); anything on an ankle-roll body is a sole, split as above. A contact
farther from every such shape maps to nothing and is returned by its geom's name.
"""

from __future__ import annotations

import weakref

import mujoco
import numpy as np

from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, FloorContact

_SOLE_MIDDLE = 0.0425
"""x of the sole's middle in the ankle-roll frame [m]."""

MESH_TOLERANCE = 0.06
"""Largest distance from a mesh contact point to the named contact it is read as [m]."""

GEOM_CONTACTS: dict[str, str] = {
    **{name: name for name in FLOOR_CONTACTS
       if name not in ("back", "chest") and not name.endswith(("_foot", "_toes", "_heel"))},
    "hip_yaw_motors": "hip_motors",
    "left_foot_sole": "left_foot", "right_foot_sole": "right_foot", "torso": "torso",
}
"""Collision geom name → named contact (``<side>_foot`` and ``torso`` split by where the
contact lies)."""

_DERIVED = {name for name in FLOOR_CONTACTS if name.endswith(("_toes", "_heel"))}
"""Named contacts that are parts of another (a sole's toes and heel edges)."""


def shape_distance(contact: FloorContact, origin: np.ndarray, rotation: np.ndarray,
                   points: np.ndarray) -> np.ndarray:
    """Signed distances from world points to a named contact's shape [m], negative inside
    it: a sphere (one centre), a capsule (two axis ends) or a rectangle (four corners
    c₀…c₃ with c₁ − c₀ ⟂ c₂ − c₀, as :mod:`hybrid_recovery.getup.contacts` lists them),
    grown by its radius. A point inside two shapes is nearer the one it lies deeper in.

    Args:
        contact: The named contact.
        origin: Its body's origin in the world, shape (3,) [m].
        rotation: Its body's orientation (body → world), shape (3, 3).
        points: World points, shape (..., 3) [m].

    Returns:
        Distances, shape (...) [m].
    """
    c = origin + np.asarray(contact.points, dtype=float) @ rotation.T
    rel = np.asarray(points, dtype=float) - c[0]
    axes = c[1:3] - c[0] if len(c) == 4 else c[1:2] - c[0]  # none, one, two edges
    offset = rel.copy()
    for axis in axes:
        offset -= np.clip(rel @ axis / (axis @ axis), 0.0, 1.0)[..., None] * axis
    return np.linalg.norm(offset, axis=-1) - contact.radius


_NEARBY: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""Per model: body → the named contacts on it and the bodies next to it in the tree."""


def _nearby_contacts(model: mujoco.MjModel, body: int) -> list[tuple[FloorContact, int]]:
    table = _NEARBY.setdefault(model, {})
    if body not in table:
        near = {body, int(model.body_parentid[body]),
                *np.flatnonzero(model.body_parentid == body)}
        names = {model.body(int(b)).name: int(b) for b in near if b > 0}
        table[body] = [(c, names[c.body]) for c in FLOOR_CONTACTS.values()
                       if c.body in names and c.name not in _DERIVED]
    return table[body]


def _read_mesh_contacts(model: mujoco.MjModel, data: mujoco.MjData, geom: int,
                        points: np.ndarray) -> set[str]:
    """For each contact point (k, 3) the named contact nearest it within
    ``MESH_TOLERANCE``, as a set (empty: none)."""
    nearby = _nearby_contacts(model, int(model.geom_bodyid[geom]))
    if not nearby:
        return set()
    distances = np.array([shape_distance(c, data.xpos[b], data.xmat[b].reshape(3, 3), points)
                          for c, b in nearby])
    best = distances.argmin(axis=0)
    return {nearby[i][0].name for i, d in zip(best, distances.min(axis=0), strict=True)
            if d <= MESH_TOLERANCE}


def _split(data: mujoco.MjData, body: int, name: str, positions: np.ndarray) -> set[str]:
    local = (positions - data.xpos[body]) @ data.xmat[body].reshape(3, 3)
    if name == "torso":
        return {"back" if x < 0.0 else "chest" for x in local[:, 0]}
    side = name.removesuffix("_foot")
    parts = {f"{side}_toes" if x > _SOLE_MIDDLE else f"{side}_heel" for x in local[:, 0]}
    return {f"{side}_foot"} if len(parts) == 2 else parts


def touching_geoms(model: mujoco.MjModel, data: mujoco.MjData) -> dict[int, np.ndarray]:
    """Robot geoms touching the world body (the floor) → their contact points, shape
    (k, 3) [m]."""
    n = data.ncon
    geoms = data.contact.geom[:n]
    on_floor = model.geom_bodyid[geoms] == 0
    keep = on_floor[:, 0] != on_floor[:, 1]
    robot = np.where(on_floor[:, 0], geoms[:, 1], geoms[:, 0])[keep]
    points = data.contact.pos[:n][keep]
    return {int(g): points[robot == g] for g in np.unique(robot)}


def _read_geom(model: mujoco.MjModel, data: mujoco.MjData, geom: int,
               positions: np.ndarray) -> set[str]:
    """The named contacts one touching geom is read as (empty: none)."""
    body = int(model.geom_bodyid[geom])
    name = GEOM_CONTACTS.get(model.geom(geom).name)
    if name is None:
        body_name = model.body(body).name
        if body_name.endswith("_ankle_roll_link"):
            name = body_name.removesuffix("_ankle_roll_link") + "_foot"
        else:
            return _read_mesh_contacts(model, data, geom, positions)
    if name == "torso" or name.endswith("_foot"):
        return _split(data, body, name, positions)
    return {name}


def touching_bodies(model: mujoco.MjModel, data: mujoco.MjData) -> frozenset[str]:
    """Names of the robot's bodies whose geoms touch the world body (the floor)."""
    return frozenset(model.body(int(model.geom_bodyid[g])).name
                     for g in touching_geoms(model, data))


def _readings(model: mujoco.MjModel, data: mujoco.MjData) -> list[tuple[int, set[str]]]:
    """Each touching geom with the named contacts it is read as (empty: none)."""
    return [(geom, _read_geom(model, data, geom, points))
            for geom, points in touching_geoms(model, data).items()]


def floor_contacts(model: mujoco.MjModel, data: mujoco.MjData
                   ) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The named contacts touching the floor (world body) in ``data``'s contact list.

    Args:
        model: Compiled model of the H1-2 on a floor.
        data: A forwarded state (``data.contact`` current).

    Returns:
        (named contacts, sorted; names of touching geoms that map to none).
    """
    readings = _readings(model, data)
    named = set().union(*(names for _, names in readings))
    unmapped = {model.geom(geom).name or f"geom {geom}" for geom, names in readings if not names}
    return tuple(sorted(named)), tuple(sorted(unmapped))


def floor_bodies(model: mujoco.MjModel, data: mujoco.MjData) -> frozenset[str]:
    """The bodies touching the floor as the named contacts read them: each named contact's
    body (a thigh mesh touching at the knee: the knee link), the own body of a geom that
    maps to none. On the project's model, :func:`touching_bodies`."""
    bodies: set[str] = set()
    for geom, names in _readings(model, data):
        bodies |= ({FLOOR_CONTACTS[n].body for n in names} if names
                   else {model.body(int(model.geom_bodyid[geom])).name})
    return frozenset(bodies)


def maps_contacts(model: mujoco.MjModel) -> bool:
    """Whether every named contact has a collision geom in ``model`` (by the names of
    :data:`GEOM_CONTACTS`): the project's model. The manufacturer's mesh model has none
    (its contacts are read by where they touch)."""
    geoms = {model.geom(i).name for i in range(model.ngeom)}
    return set(GEOM_CONTACTS.values()) <= {GEOM_CONTACTS[g] for g in geoms & GEOM_CONTACTS.keys()}
