"""Pinocchio model built from a compiled MuJoCo model (one source of truth).

The kinematic tree, joint frames and axes, masses and inertias are read from the
compiled ``mujoco.MjModel``, so Pinocchio sees exactly what MuJoCo simulates, whatever
the MJCF's quirks (defaults, ``fromto``, several ``<worldbody>`` elements, a root body
with a ``pos``). Joint order is MuJoCo's, so ``q[7:] == qpos[7:]``.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin

_AXES = {(1.0, 0.0, 0.0): pin.JointModelRX, (0.0, 1.0, 0.0): pin.JointModelRY,
         (0.0, 0.0, 1.0): pin.JointModelRZ}


def _se3(quat_wxyz: np.ndarray, pos: np.ndarray) -> pin.SE3:
    w, x, y, z = quat_wxyz
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.asarray(pos, float))


def _inertia(mj: mujoco.MjModel, body: int, offset: pin.SE3) -> pin.Inertia:
    """Spatial inertia of ``body`` expressed in a frame placed at ``offset`` (body → frame)."""
    rot = _se3(mj.body_iquat[body], np.zeros(3)).rotation
    local = pin.Inertia(float(mj.body_mass[body]), mj.body_ipos[body].copy(),
                        rot @ np.diag(mj.body_inertia[body]) @ rot.T)
    return offset.act(local)


def _joint_model(axis: np.ndarray) -> pin.JointModel:
    key = tuple(float(round(a, 12)) for a in axis / np.linalg.norm(axis))
    if key in _AXES:
        return _AXES[key]()
    return pin.JointModelRevoluteUnaligned(axis / np.linalg.norm(axis))


def build_pinocchio_model(mj: mujoco.MjModel) -> pin.Model:
    """Builds the Pinocchio model of a floating-base robot from a compiled MuJoCo model.

    Args:
        mj: Compiled model whose first joint is a free joint on a child of the world, and
            whose other joints are hinges (at most one per body). Bodies without joints are
            welded to their parent.

    Returns:
        Pinocchio model with a free-flyer root (nq = mj.nq, nv = mj.nv), one frame per
        MuJoCo body and one per site, named as in MuJoCo.

    Raises:
        ValueError: if the model has no free joint at its root, or unsupported joints.
    """
    if mj.njnt == 0 or mj.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE or mj.jnt_bodyid[0] < 1:
        raise ValueError("model has no free joint: a floating-base robot needs one at its root")
    root = int(mj.jnt_bodyid[0])
    model = pin.Model()
    model.name = mj.names.split(b"\x00", 1)[0].decode() or "robot"
    # MuJoCo body id -> (pinocchio joint id, placement of the body frame in that joint frame)
    attach: dict[int, tuple[int, pin.SE3]] = {}
    for body in range(1, mj.nbody):
        name = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_BODY, body)
        parent = int(mj.body_parentid[body])
        if parent == 0 and body != root:
            raise ValueError(f"body '{name}' is a second root: only one floating base is supported")
        if body == root:
            parent_joint, parent_pose = 0, pin.SE3.Identity()
            body_in_parent = pin.SE3.Identity()  # the free joint places the body frame itself
        else:
            parent_joint, parent_pose = attach[parent]
            body_in_parent = _se3(mj.body_quat[body], mj.body_pos[body])
        placement = parent_pose * body_in_parent
        njnt, first = int(mj.body_jntnum[body]), int(mj.body_jntadr[body])
        if njnt > 1:
            raise ValueError(f"body '{name}' has {njnt} joints: at most one per body is supported")
        if njnt == 0:
            joint_id, in_joint = parent_joint, placement
        else:
            jtype = mj.jnt_type[first]
            offset = pin.SE3(np.eye(3), mj.jnt_pos[first].copy())
            if body == root:
                jmodel: pin.JointModel = pin.JointModelFreeFlyer()
            elif jtype == mujoco.mjtJoint.mjJNT_HINGE:
                jmodel = _joint_model(mj.jnt_axis[first])
            else:
                raise ValueError(f"joint '{mj.joint(first).name}' of type {int(jtype)} "
                                 "is not supported")
            jname = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_JOINT, first) or f"{name}_joint"
            joint_id = model.addJoint(parent_joint, jmodel, placement * offset, jname)
            if jtype == mujoco.mjtJoint.mjJNT_HINGE:
                if mj.jnt_limited[first]:
                    model.lowerPositionLimit[model.idx_qs[joint_id]] = mj.jnt_range[first, 0]
                    model.upperPositionLimit[model.idx_qs[joint_id]] = mj.jnt_range[first, 1]
                model.armature[model.idx_vs[joint_id]] = mj.dof_armature[mj.jnt_dofadr[first]]
            in_joint = offset.inverse()
        model.appendBodyToJoint(joint_id, _inertia(mj, body, in_joint), pin.SE3.Identity())
        model.addFrame(pin.Frame(name, joint_id, in_joint, pin.FrameType.BODY))
        attach[body] = (joint_id, in_joint)
    for site in range(mj.nsite):
        body = int(mj.site_bodyid[site])
        if body == 0:
            continue
        joint_id, in_joint = attach[body]
        pose = in_joint * _se3(mj.site_quat[site], mj.site_pos[site])
        frame = pin.Frame(mj.site(site).name, joint_id, pose, pin.FrameType.OP_FRAME)
        model.addFrame(frame)
    if model.nq != mj.nq or model.nv != mj.nv:
        raise ValueError(f"converted model has nq={model.nq}, nv={model.nv}; MuJoCo has "
                         f"nq={mj.nq}, nv={mj.nv}")
    return model
