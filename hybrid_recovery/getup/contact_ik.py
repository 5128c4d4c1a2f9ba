"""Contact keyframes by whole-body IK (placo): a pose with named floor contacts held.

Each keyframe is a posture (joint targets near which to stay), a base orientation to
start from, and the floor contacts it rests on. placo's kinematics solver places every
load-bearing point of those contacts on the floor (sphere centres at their radius, sole
or box corners at z = 0) as weighted tasks, keeps the posture as a low-weight joint task
and the joints within their ranges × ``range_factor``. The robot is described to placo
by a URDF written from the compiled MuJoCo model
(:func:`hybrid_recovery.robot.urdf.urdf_from_mjmodel`), with a fixed frame per contact
point.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import placo

from hybrid_recovery.getup.contacts import FLOOR_CONTACTS, contact_points_in
from hybrid_recovery.getup.keyframes import (
    HANDS_KNEES,
    KNEE_CHEST,
    KNEEL_UPRIGHT,
    PRONE_HANDS,
    SIDE_SIT,
    _symmetric,
)
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses
from hybrid_recovery.robot.urdf import urdf_from_mjmodel

SITTING_KNEES_BENT = _symmetric((0.0, -2.1, 0.0, 2.0, 0.45, 0.03), 0.0,
                                (0.5, 0.18, 0.0, 1.43, 0.0, 0.0, 0.0))
"""Sitting on the pelvis, knees bent, heels down, hands on the floor behind (the ankle's
0.9× range keeps the soles from lying flat)."""


@dataclass(frozen=True)
class ContactKeyframe:
    """A posture q° (27,) [rad], a base orientation (w, x, y, z) and its floor contacts."""

    posture: np.ndarray
    base_quat: tuple[float, float, float, float]
    contacts: tuple[str, ...]


_HANDS = ("left_hand", "right_hand")
_TOES = ("left_toes", "right_toes")
_KNEES = ("left_knee", "right_knee")
CONTACT_KEYFRAMES: dict[str, ContactKeyframe] = {
    "prone": ContactKeyframe(PRONE_HANDS, (0.7071, 0.0, 0.7071, 0.0), ("head", *_HANDS, *_TOES)),
    "knee_chest": ContactKeyframe(KNEE_CHEST, (0.522, 0.0, 0.853, 0.0),
                                  (*_KNEES, *_TOES, *_HANDS, "head")),
    "hands_knees": ContactKeyframe(HANDS_KNEES, (0.796, 0.0, 0.605, 0.0),
                                   (*_KNEES, *_TOES, *_HANDS)),
    "kneel_upright": ContactKeyframe(KNEEL_UPRIGHT, (1.0, 0.0, 0.0, 0.0), (*_KNEES, *_TOES)),
    "sitting": ContactKeyframe(SITTING_KNEES_BENT, (0.975, 0.0, -0.2235, 0.0),
                               ("pelvis", "left_heel", "right_heel", *_HANDS)),
    "side_sit": ContactKeyframe(SIDE_SIT, (0.865, -0.456, -0.029, 0.209),
                                ("left_hip", *_HANDS, "right_foot")),
}
"""The ground keyframes: prone, knee-chest, hands and knees, kneeling upright, sitting,
side-sit."""


@dataclass
class IkResult:
    """A solved keyframe.

    Attributes:
        qpos: MuJoCo configuration, shape (nq,).
        contact_heights: Height above its target of every load-bearing point, by
            contact, each (k,) [m] (0: on the floor).
        range_use: max_j |q_j − mid_j| / half-range_j of the joints [-] (≤ range_factor:
            within the scaled ranges).
    """

    qpos: np.ndarray
    contact_heights: dict[str, np.ndarray]
    range_use: float


def _frames() -> dict[str, tuple[str, tuple[float, float, float]]]:
    return {f"{name}_{k}": (c.body, p) for name, c in FLOOR_CONTACTS.items()
            for k, p in enumerate(c.points)}


SEED_BAND = 0.03
"""Corners of a flat part within this height of its lowest corner in the seed pose bear
load [m] (a flat sole: four; a tilted pelvis: its lower edge)."""


def _load_points(robot: placo.RobotWrapper, name: str) -> list[int]:
    """Indices of a contact's load-bearing points in the robot's current pose."""
    count = len(FLOOR_CONTACTS[name].points)
    heights = np.array([robot.get_T_world_frame(f"{name}_{k}")[2, 3] for k in range(count)])
    return [int(k) for k in np.flatnonzero(heights <= heights.min() + SEED_BAND)]


class ContactIk:
    """placo's kinematics solver on a robot model.

    Args:
        model: Compiled MuJoCo model of the H1-2 (free joint at the root).
        range_factor: Joint ranges scaled about their middle by this.
    """

    def __init__(self, model: mujoco.MjModel, range_factor: float = 0.9) -> None:
        self.model = model
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "robot.urdf"
            path.write_text(urdf_from_mjmodel(model, _frames()))
            self.robot = placo.RobotWrapper(str(path), 0)
        lo, hi = SafetyLimits.from_model(model).q_ref_bounds(range_factor)
        self.lo, self.hi, self.range_factor = lo, hi, range_factor
        for name, a, b in zip(constants.JOINT_NAMES, lo, hi, strict=True):
            self.robot.set_joint_limits(name, float(a), float(b))
        self._qadr = joint_addresses(model)[0]

    def solve(self, keyframe: ContactKeyframe, iterations: int = 300,
              com_over: tuple[str, ...] = ()) -> IkResult:
        """Places ``keyframe``'s contacts on the floor near its posture.

        Args:
            keyframe: The posture, base orientation and floor contacts.
            iterations: Solver iterations.
            com_over: Contacts (of ``keyframe.contacts``) over the mean of whose
                middles (each contact's load-bearing points averaged) the CoM's ground
                projection is placed, once the contacts have landed and are pinned where
                they landed (a soft task below the contacts' weight); empty: the CoM is
                free.
        """
        robot = self.robot
        posture = np.clip(keyframe.posture, self.lo, self.hi)
        for name, q in zip(constants.JOINT_NAMES, posture, strict=True):
            robot.set_joint(name, float(q))
        base = np.eye(4)
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, np.asarray(keyframe.base_quat, float)
                            / np.linalg.norm(keyframe.base_quat))
        base[:3, :3] = rot.reshape(3, 3)
        base[2, 3] = 0.5
        robot.set_T_world_fbase(base)
        robot.update_kinematics()
        points = {name: _load_points(robot, name) for name in keyframe.contacts}
        solver = placo.KinematicsSolver(robot)
        solver.enable_joint_limits(True)
        solver.enable_velocity_limits(False)
        tasks = {}
        for name in keyframe.contacts:
            radius = FLOOR_CONTACTS[name].radius
            for k in points[name]:
                task = solver.add_position_task(f"{name}_{k}", np.array([0.0, 0.0, radius]))
                task.mask.set_axises("z")
                task.configure(f"{name}_{k}", "soft", 1e4)
                tasks[f"{name}_{k}"] = task
        joints = solver.add_joints_task()
        joints.set_joints({n: float(q) for n, q in zip(constants.JOINT_NAMES, posture,
                                                        strict=True)})
        joints.configure("posture", "soft", 1.0)
        solver.add_regularization_task(1e-4)
        for _ in range(iterations):
            solver.solve(True)
            robot.update_kinematics()
        if com_over:  # pin the contacts where they landed, then carry the CoM over
            for frame, task in tasks.items():
                task.target_world = robot.get_T_world_frame(frame)[:3, 3] * [1, 1, 0] + [
                    0.0, 0.0, float(task.target_world[2])]
                task.mask.set_axises("xyz")
            com = solver.add_com_task(np.mean(
                [np.mean([robot.get_T_world_frame(f"{name}_{k}")[:3, 3] for k in points[name]],
                         axis=0) for name in com_over], axis=0))
            com.mask.set_axises("xy")
            com.configure("com", "soft", 1e3)
            for _ in range(iterations):
                solver.solve(True)
                robot.update_kinematics()
        return self._result(keyframe, points)

    def _result(self, keyframe: ContactKeyframe, points: dict[str, list[int]]) -> IkResult:
        robot, model = self.robot, self.model
        qpos = np.zeros(model.nq)
        pose = robot.get_T_world_fbase()
        qpos[:3] = pose[:3, 3]
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, pose[:3, :3].reshape(-1).copy())
        qpos[3:7] = quat
        qpos[self._qadr] = [robot.get_joint(n) for n in constants.JOINT_NAMES]
        data = mujoco.MjData(model)
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        heights = {}
        for name in keyframe.contacts:
            world = contact_points_in(model, data, FLOOR_CONTACTS[name])
            heights[name] = world[points[name], 2]
        mid, half = (self.lo + self.hi) / 2, (self.hi - self.lo) / 2 / self.range_factor
        use = float(np.max(np.abs(qpos[self._qadr] - mid) / half))
        return IkResult(qpos, heights, use)
