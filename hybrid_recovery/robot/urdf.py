"""A URDF description written from a compiled MuJoCo model (for URDF-only tools: placo).

Kinematics and inertias only (no geometry): one link per body, a revolute joint per
hinge (range, effort limit from ``constants.EFFORT_LIMITS`` by name), fixed joints for
bodies without joints, and optional extra fixed frames (e.g. contact points). The free
joint at the root is left out: URDF tools add the floating base themselves.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.robot import constants


def _rpy(quat_wxyz: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (R = R_z(y) R_y(p) R_x(r)) of a unit quaternion."""
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(quat_wxyz, dtype=float))
    r = rot.reshape(3, 3)
    pitch = float(np.arcsin(np.clip(-r[2, 0], -1.0, 1.0)))
    roll = float(np.arctan2(r[2, 1], r[2, 2]))
    yaw = float(np.arctan2(r[1, 0], r[0, 0]))
    return roll, pitch, yaw


def _origin(pos: np.ndarray, quat: np.ndarray) -> str:
    r, p, y = _rpy(quat)
    return (f'<origin xyz="{pos[0]:.9g} {pos[1]:.9g} {pos[2]:.9g}" '
            f'rpy="{r:.12g} {p:.12g} {y:.12g}"/>')


def urdf_from_mjmodel(model: mujoco.MjModel,
                      frames: dict[str, tuple[str, tuple[float, float, float]]] | None = None
                      ) -> str:
    """URDF text of ``model``'s robot.

    Args:
        model: Compiled model with a free joint at its root, hinges elsewhere (no joint
            offsets), at most one joint per body.
        frames: Extra fixed frames: name → (parent body, position in the body frame [m]).

    Returns:
        The URDF document.

    Raises:
        ValueError: a joint with an offset or of an unsupported type.
    """
    effort = dict(zip(constants.JOINT_NAMES, constants.EFFORT_LIMITS, strict=True))
    out = [f'<robot name="{model.body(1).name}_robot">']
    for body in range(1, model.nbody):
        name = model.body(body).name
        quat = model.body_iquat[body]
        inertia = model.body_inertia[body]
        out.append(f'<link name="{name}"><inertial>{_origin(model.body_ipos[body], quat)}'
                   f'<mass value="{model.body_mass[body]:.9g}"/>'
                   f'<inertia ixx="{inertia[0]:.9g}" iyy="{inertia[1]:.9g}" '
                   f'izz="{inertia[2]:.9g}" ixy="0" ixz="0" iyz="0"/></inertial></link>')
        if model.body_parentid[body] == 0:
            continue
        parent = model.body(int(model.body_parentid[body])).name
        origin = _origin(model.body_pos[body], model.body_quat[body])
        if model.body_jntnum[body] == 0:
            out.append(f'<joint name="{name}_fixed" type="fixed"><parent link="{parent}"/>'
                       f'<child link="{name}"/>{origin}</joint>')
            continue
        jnt = int(model.body_jntadr[body])
        jname = model.joint(jnt).name
        if model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_HINGE or np.any(model.jnt_pos[jnt]):
            raise ValueError(f"joint '{jname}': only hinges without an offset are supported")
        lo, hi = model.jnt_range[jnt]
        axis = model.jnt_axis[jnt]
        out.append(f'<joint name="{jname}" type="revolute"><parent link="{parent}"/>'
                   f'<child link="{name}"/>{origin}'
                   f'<axis xyz="{axis[0]:.9g} {axis[1]:.9g} {axis[2]:.9g}"/>'
                   f'<limit lower="{lo:.9g}" upper="{hi:.9g}" '
                   f'effort="{effort.get(jname, 0.0):.9g}" velocity="30"/></joint>')
    for name, (parent, pos) in (frames or {}).items():
        out.append(f'<link name="{name}"/><joint name="{name}_fixed" type="fixed">'
                   f'<parent link="{parent}"/><child link="{name}"/>'
                   f'<origin xyz="{pos[0]:.9g} {pos[1]:.9g} {pos[2]:.9g}" rpy="0 0 0"/></joint>')
    out.append("</robot>")
    return "\n".join(out)
