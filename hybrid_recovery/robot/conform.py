"""Making any H1-2 MJCF behave as the project's robot: one rule set for every loader.

The project's own model (``models/h1_2/h1_2.xml``) already conforms; another H1-2 file
(e.g. the manufacturer's mesh model) is brought to the same conventions here, so that
evaluation, sim-to-sim, rendering and the QP controller all see the same robot:

* integrator ``implicitfast`` (the PD damping integrated implicitly, as in training; a
  file without ``<option>`` would otherwise get MuJoCo's explicit Euler);
* floor-only contacts: every robot collision geom ``contype = 1, conaffinity = 0``, the
  floor ``contype = 0, conaffinity = 1`` (no self-collision, as in the project's model);
* the sites the controllers read, derived from the bodies where the file lacks them (and
  has the bodies):
  ``<side>_foot`` (sole centre, on the sole's bottom face), the sole corners
  ``<side>_foot_{fl,fr,rl,rr}`` (from the foot's collision geometry) and ``imu`` (the
  torso link's origin);
* optionally the project's rotor inertia (joint armature) for a file that has none.
"""

from __future__ import annotations

import functools
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.robot import constants

SIDES: tuple[str, str] = ("left", "right")
CORNERS: tuple[str, ...] = ("fl", "fr", "rl", "rr")
"""Sole corners: front/rear (±x of the foot body), left/right (±y)."""
IMU_SITE = "imu"


def sole_site_names() -> list[str]:
    """``<side>_foot`` and ``<side>_foot_<corner>`` for both sides."""
    return [f"{s}_foot" for s in SIDES] + [f"{s}_foot_{c}" for s in SIDES for c in CORNERS]


def conform_spec(spec: mujoco.MjSpec, floor_name: str, rotor_inertia: bool = False) -> None:
    """Applies the project's conventions (module docstring) to ``spec`` in place.

    Args:
        spec: A parsed H1-2 MJCF (joints of ``constants.JOINT_NAMES``).
        floor_name: Name of the ground plane geom (may be absent).
        rotor_inertia: Set every joint's armature to the project's model's value
            [kg·m²] (the reflected rotor inertia, which the manufacturer's file lacks).
    """
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    for geom in spec.geoms:
        if geom.name == floor_name:
            geom.contype, geom.conaffinity = 0, 1
        elif geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity = 1, 0
    if rotor_inertia:
        for name, armature in zip(constants.JOINT_NAMES, project_armature(), strict=True):
            spec.joint(name).armature = armature
    _add_missing_sites(spec)


@functools.cache
def project_armature() -> tuple[float, ...]:
    """The project's model's joint armature per joint of ``constants.JOINT_NAMES`` [kg·m²]."""
    from hybrid_recovery.robot.mjcf import H1_2_MJCF

    model = mujoco.MjModel.from_xml_path(str(Path(H1_2_MJCF)))
    return tuple(float(model.dof_armature[model.jnt_dofadr[model.joint(n).id]])
                 for n in constants.JOINT_NAMES)


def collision_points(model: mujoco.MjModel, body: int) -> np.ndarray:
    """Points bounding the body's collision geoms, in the body frame, shape (P, 3) [m].

    Mesh geoms contribute their vertices (exact); other shapes the 8 corners of their
    bounding box in the geom frame.
    """
    points = []
    for g in np.flatnonzero(model.geom_bodyid == body):
        if not (model.geom_contype[g] or model.geom_conaffinity[g]):
            continue
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = model.geom_dataid[g]
            adr, n = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            local = model.mesh_vert[adr:adr + n].astype(float)
        else:
            centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
            signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
            local = centre + signs * half
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        points.append(model.geom_pos[g] + local @ rot.reshape(3, 3).T)
    if not points:
        raise ValueError(f"body '{model.body(body).name}' has no collision geom to derive "
                         "sole sites from")
    return np.concatenate(points)


def sole_sites(model: mujoco.MjModel, body: int) -> dict[str, np.ndarray]:
    """Sole centre and corners of a foot body in its frame [m]: the bottom face of the
    collision geometry's bounding box (the soles are flat in the body's x–y plane).

    Returns:
        ``{"centre": (3,), "fl": (3,), "fr": (3,), "rl": (3,), "rr": (3,)}``.
    """
    points = collision_points(model, body)
    lo, hi = points.min(0), points.max(0)
    z = lo[2]
    return {"centre": np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, z]),
            "fl": np.array([hi[0], hi[1], z]), "fr": np.array([hi[0], lo[1], z]),
            "rl": np.array([lo[0], hi[1], z]), "rr": np.array([lo[0], lo[1], z])}


def _add_missing_sites(spec: mujoco.MjSpec) -> None:
    names = {site.name for site in spec.sites}
    missing_soles = any(n not in names for n in sole_site_names())
    if not missing_soles and IMU_SITE in names:
        return
    bodies = {body.name for body in spec.bodies}
    feet = [(s, b) for s, b in zip(SIDES, constants.FOOT_BODIES, strict=True) if b in bodies]
    if missing_soles and feet:
        model = spec.compile()
        for side, body_name in feet:
            sites = sole_sites(model, model.body(body_name).id)
            body = spec.body(body_name)
            if f"{side}_foot" not in names:
                body.add_site(name=f"{side}_foot", pos=sites["centre"])
            for corner in CORNERS:
                if f"{side}_foot_{corner}" not in names:
                    body.add_site(name=f"{side}_foot_{corner}", pos=sites[corner])
    if IMU_SITE not in names and constants.TORSO_BODY in bodies:
        spec.body(constants.TORSO_BODY).add_site(name=IMU_SITE, pos=[0.0, 0.0, 0.0])
