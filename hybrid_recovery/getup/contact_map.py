"""The named floor contacts of a MuJoCo state: MuJoCo's robot–floor contacts, by geom.

Every collision geom of the project's H1-2 (``models/h1_2/h1_2.xml``) is one of the
named contacts of :data:`hybrid_recovery.getup.contacts.FLOOR_CONTACTS`, except two that
several named contacts share:

* a sole: ``<side>_toes`` where it touches ahead of the sole's middle (x > 0.0425 m in
  the ankle-roll frame), ``<side>_heel`` behind it, ``<side>_foot`` where both;
* the torso box: ``back`` where it touches behind the torso's mid-plane (x < 0 in the
  torso frame), ``chest`` in front of it.

Geoms of other models (meshes) map to nothing and are returned by name.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.getup.contacts import FLOOR_CONTACTS

_SOLE_MIDDLE = 0.0425
"""x of the sole's middle in the ankle-roll frame [m]."""

GEOM_CONTACTS: dict[str, str] = {
    **{name: name for name in FLOOR_CONTACTS
       if name not in ("back", "chest") and not name.endswith(("_foot", "_toes", "_heel"))},
    "hip_yaw_motors": "hip_motors",
    "left_foot_sole": "left_foot", "right_foot_sole": "right_foot", "torso": "torso",
}
"""Collision geom name → named contact (``<side>_foot`` and ``torso`` split by where the
contact lies)."""


def _split(model: mujoco.MjModel, data: mujoco.MjData, geom: int, name: str,
           positions: list[np.ndarray]) -> set[str]:
    body = model.geom_bodyid[geom]
    local = (np.array(positions) - data.xpos[body]) @ data.xmat[body].reshape(3, 3)
    if name == "torso":
        return {"back" if x < 0.0 else "chest" for x in local[:, 0]}
    side = name.removesuffix("_foot")
    parts = {f"{side}_toes" if x > _SOLE_MIDDLE else f"{side}_heel" for x in local[:, 0]}
    return {f"{side}_foot"} if len(parts) == 2 else parts


def floor_contacts(model: mujoco.MjModel, data: mujoco.MjData
                   ) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The named contacts touching the floor (world body) in ``data``'s contact list.

    Args:
        model: Compiled model of the H1-2 on a floor.
        data: A forwarded state (``data.contact`` current).

    Returns:
        (named contacts, sorted; names of touching geoms that map to none).
    """
    touching: dict[int, list[np.ndarray]] = {}
    for c in data.contact[:data.ncon]:
        b0, b1 = model.geom_bodyid[c.geom[0]], model.geom_bodyid[c.geom[1]]
        if (b0 == 0) == (b1 == 0):
            continue
        geom = int(c.geom[1] if b0 == 0 else c.geom[0])
        touching.setdefault(geom, []).append(np.array(c.pos))
    named: set[str] = set()
    unmapped: set[str] = set()
    for geom, positions in touching.items():
        gname = model.geom(geom).name
        name = GEOM_CONTACTS.get(gname)
        if name is None:
            unmapped.add(gname or f"geom {geom}")
        elif name == "torso" or name.endswith("_foot"):
            named |= _split(model, data, geom, name, positions)
        else:
            named.add(name)
    return tuple(sorted(named)), tuple(sorted(unmapped))


def maps_contacts(model: mujoco.MjModel) -> bool:
    """Whether every named contact has a collision geom in ``model`` (by the names of
    :data:`GEOM_CONTACTS`): the moves' contact states can be checked on it. The
    manufacturer's mesh model has none."""
    geoms = {model.geom(i).name for i in range(model.ngeom)}
    return set(GEOM_CONTACTS.values()) <= {GEOM_CONTACTS[g] for g in geoms & GEOM_CONTACTS.keys()}
