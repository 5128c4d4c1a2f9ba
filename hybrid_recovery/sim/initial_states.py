"""Initial states: standing, squatting, kneeling, sitting, supine and prone, settled.

Each pose is a joint configuration and a base orientation. A pool of physically valid
states per pose is made once per environment by dropping the robot from just above the
ground and letting it settle for ``settle_time`` under PD holding the pose, with the
paper's joint noise applied before settling. Episodes then start from a pool entry with
the paper's initialisation noise, re-seated so that no geom is below the ground.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from hybrid_recovery.robot import constants
from hybrid_recovery.sim.backend import PhysicsBatch

POSES = ("standing", "squatting", "kneeling", "sitting", "supine", "prone", "half_kneeling")
"""The paper's six start poses, then the half-kneel, a stepping stone beyond the paper
(weight 0 by default)."""


@dataclass(frozen=True)
class Pose:
    """A named start pose: joint targets q (27,) [rad], base pitch [rad], and how long it
    settles [s] (upright poses only until their contacts are established)."""

    joints: np.ndarray
    pitch: float
    settle_time: float = 1.5
    mirrored: bool = False
    """Half of the pool is the left–right mirror image (for asymmetric poses)."""


def _joints(hip_pitch: float, knee: float, ankle: float, shoulder: float = 0.2,
            elbow: float = 0.6, torso: float = 0.0, shoulder_roll: float = 0.2) -> np.ndarray:
    leg = [0.0, hip_pitch, 0.0, knee, ankle, 0.0]
    left_arm = [shoulder, shoulder_roll, 0.0, elbow, 0.0, 0.0, 0.0]
    right_arm = [shoulder, -shoulder_roll, 0.0, elbow, 0.0, 0.0, 0.0]
    return np.array(leg + leg + [torso] + left_arm + right_arm)


POSE_LIBRARY: dict[str, Pose] = {
    "standing": Pose(constants.DEFAULT_JOINT_POS.copy(), 0.0, settle_time=0.2),
    # deep squat: thighs near horizontal, heels down, arms forward for balance
    "squatting": Pose(_joints(-1.5, 2.1, -0.6, shoulder=-0.8, elbow=0.3), 0.35, settle_time=0.3),
    # kneeling upright on both knees, shins on the ground, feet extended
    "kneeling": Pose(_joints(-0.1, 2.1, 0.4), 0.0),
    # sitting on the pelvis, legs forward, hands behind on the ground
    "sitting": Pose(_joints(-1.5, 0.3, 0.0, shoulder=0.6, elbow=0.2), 0.0),
    # lying on the back / the front, limbs at rest
    "supine": Pose(_joints(-0.1, 0.2, 0.0, shoulder=0.0, elbow=0.3), -np.pi / 2),
    "prone": Pose(_joints(-0.1, 0.2, 0.0, shoulder=0.0, elbow=0.3), np.pi / 2),
    # one knee down (shin on the ground, foot extended), the other foot flat in front;
    # settled until the knee lands (0.4 s): held longer under PD it tips over backwards
    "half_kneeling": Pose(np.concatenate([_joints(-1.5, 1.6, -0.1)[:6],
                                          _joints(-0.1, 1.6, 0.4)[6:]]), 0.0,
                          settle_time=0.4, mirrored=True),
}


def quat_from_euler(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Quaternions (w, x, y, z) of R = Rz(yaw) Ry(pitch) Rx(roll), shape (..., 4)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy], -1)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a ⊗ b of (w, x, y, z) quaternions, shape (..., 4)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw],
                    -1)


def lowest_point(model: mujoco.MjModel, geom_xpos: np.ndarray, geom_xmat: np.ndarray,
                 geoms: np.ndarray) -> np.ndarray:
    """Lowest z over the given collision geoms (exact for spheres, capsules, boxes and
    meshes (their vertices); the bounding sphere for other shapes).

    Args:
        model: the model (sizes and types of the geoms).
        geom_xpos: (N, ngeom, 3); geom_xmat: (N, ngeom, 9).
        geoms: ids of the geoms to consider, (G,).

    Returns:
        min z, shape (N,) [m].
    """
    pos = geom_xpos[:, geoms]
    mat = geom_xmat[:, geoms].reshape(len(pos), len(geoms), 3, 3)
    size = model.geom_size[geoms]
    gtype = model.geom_type[geoms]
    z_axis = mat[:, :, 2, :]  # the geom's axes' world-z components, (N, G, 3)
    box = np.sum(np.abs(z_axis) * size, -1)
    capsule = np.abs(z_axis[..., 2]) * size[:, 1] + size[:, 0]
    sphere = np.broadcast_to(size[:, 0], box.shape)
    other = np.broadcast_to(model.geom_rbound[geoms], box.shape)  # meshes: bounding sphere
    extent = np.select([gtype == mujoco.mjtGeom.mjGEOM_BOX, gtype == mujoco.mjtGeom.mjGEOM_CAPSULE,
                        gtype == mujoco.mjtGeom.mjGEOM_SPHERE], [box, capsule, sphere], other)
    low = pos[..., 2] - extent
    for k in np.flatnonzero(gtype == mujoco.mjtGeom.mjGEOM_MESH):
        mesh = model.geom_dataid[geoms[k]]
        adr, n = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        vert = model.mesh_vert[adr:adr + n]  # (V, 3) in the geom frame
        low[:, k] = pos[:, k, 2] + np.min(z_axis[:, k] @ vert.T, axis=1)
    return np.min(low, axis=1)


def mirror_qpos(qpos: np.ndarray, qadr: np.ndarray) -> np.ndarray:
    """The left–right mirror image of free-base configurations through the world x–z plane.

    y → −y for the base position; the base quaternion (w, x, y, z) → (w, −x, y, −z) (an
    axial vector's x and z flip); joints ``q → MIRROR_SIGN · q[MIRROR_JOINT_INDEX]``.

    Args:
        qpos: configurations, shape (..., nq).
        qadr: qpos addresses of the 27 joints in motor order, shape (27,).

    Returns:
        The mirrored configurations, shape (..., nq).
    """
    out = np.array(qpos, dtype=float, copy=True)
    out[..., 1] *= -1.0
    out[..., 4] *= -1.0
    out[..., 6] *= -1.0
    joints = np.asarray(qpos)[..., qadr]
    out[..., qadr] = constants.MIRROR_SIGN * joints[..., constants.MIRROR_JOINT_INDEX]
    return out


def robot_geoms(model: mujoco.MjModel) -> np.ndarray:
    """Ids of the robot's collision geoms (those that collide with the floor)."""
    return np.flatnonzero((model.geom_contype > 0) & (model.geom_bodyid > 0))


def settle_pool(model: mujoco.MjModel, per_pose: int, rng: np.random.Generator,
                joint_noise: float = 0.1, nthread: int = 0,
                library: Mapping[str, Pose] | None = None,
                ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Settled states of every pose of ``library`` (default :data:`POSE_LIBRARY`):
    ``{pose: (qpos (per_pose, nq), qvel (per_pose, nv))}``."""
    library = POSE_LIBRARY if library is None else library
    names = list(library)
    n = per_pose * len(names)
    sims = mjbatch.Batch(model, n, nthread, persistent=True)
    qpos, qvel, ctrl = sims.bind("qpos"), sims.bind("qvel"), sims.bind("ctrl")
    qadr = model.jnt_qposadr[1:1 + constants.NUM_JOINTS]
    targets = np.repeat(np.stack([library[p].joints for p in names]), per_pose, 0)
    for k, name in enumerate(names):
        if library[name].mirrored:
            rows = slice(k * per_pose + per_pose // 2, (k + 1) * per_pose)
            targets[rows] = constants.MIRROR_SIGN * targets[rows][:, constants.MIRROR_JOINT_INDEX]
    targets = targets + rng.uniform(-joint_noise, joint_noise, targets.shape)
    lo, hi = model.jnt_range[1:1 + constants.NUM_JOINTS].T
    targets = np.clip(targets, lo, hi)
    pitch = np.repeat([library[p].pitch for p in names], per_pose)
    qpos[:] = model.qpos0
    qvel[:] = 0.0
    qpos[:, qadr] = targets
    qpos[:, 3:7] = quat_from_euler(np.zeros(n), pitch, np.zeros(n))
    qpos[:, 2] = 2.0
    seat_on_ground(model, sims, np.arange(n), clearance=0.01)
    ctrl[:] = targets
    out, elapsed = {}, 0.0
    for k, name in sorted(enumerate(names), key=lambda kn: library[kn[1]].settle_time):
        remaining = library[name].settle_time - elapsed
        if remaining > 0:
            sims.step(nstep=int(round(remaining / model.opt.timestep)),
                      stage=mujoco.mjtStage.mjSTAGE_VEL)
            elapsed += remaining
        rows = slice(k * per_pose, (k + 1) * per_pose)
        out[name] = (qpos[rows].copy(), qvel[rows].copy())
    return out


def seat_on_ground(model: mujoco.MjModel, sims: PhysicsBatch, ids: np.ndarray,
                   clearance: float = 0.005) -> None:
    """Shifts the base of sims ``ids`` vertically so their lowest geom is at ``clearance``."""
    sims.forward(ids, stage=mujoco.mjtStage.mjSTAGE_POS)
    low = lowest_point(model, sims.bind("geom_xpos")[ids], sims.bind("geom_xmat")[ids],
                       robot_geoms(model))
    qpos = sims.bind("qpos")
    qpos[ids, 2] += clearance - low


def perturb_start(qpos: np.ndarray, rng: np.random.Generator, base_pos: float, base_rot: float,
                  joint_pos: float, qadr: np.ndarray, joint_range: np.ndarray) -> np.ndarray:
    """The paper's initialisation noise on settled states, plus a uniform random heading.

    Args:
        qpos: settled states, shape (n, nq).
        base_pos: horizontal base offset half-width [m].
        base_rot: roll/pitch/yaw noise half-width [rad].
        joint_pos: joint offset half-width [rad] (clipped to the joint ranges).
        qadr: qpos addresses of the 27 joints; joint_range: their ranges, (27, 2).

    Returns:
        Perturbed states, shape (n, nq) (heights are fixed by :func:`seat_on_ground`).
    """
    qpos = np.array(qpos, dtype=float, copy=True)
    n = len(qpos)
    qpos[:, :2] += rng.uniform(-base_pos, base_pos, (n, 2))
    rpy = rng.uniform(-base_rot, base_rot, (n, 3))
    turn = quat_from_euler(rpy[:, 0], rpy[:, 1], rpy[:, 2] + rng.uniform(-np.pi, np.pi, n))
    qpos[:, 3:7] = quat_mul(turn, qpos[:, 3:7])
    joints = qpos[:, qadr] + rng.uniform(-joint_pos, joint_pos, (n, len(qadr)))
    qpos[:, qadr] = np.clip(joints, joint_range[:, 0], joint_range[:, 1])
    return qpos


def seat_single(model: mujoco.MjModel, data: mujoco.MjData, clearance: float = 0.005) -> None:
    """:func:`seat_on_ground` for one ``MjData``."""
    mujoco.mj_kinematics(model, data)
    low = lowest_point(model, data.geom_xpos[None], data.geom_xmat.reshape(1, -1, 9),
                       robot_geoms(model))[0]
    data.qpos[2] += clearance - low
