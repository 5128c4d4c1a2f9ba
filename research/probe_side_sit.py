"""Probe: a sitting → side-sit move through knee-chest, built from IK keyframes and checked
statically along the way.

From a noisy evaluation start (``--pose sitting``: the executor's roll to prone and its
tuck to knee-chest first; ``--pose prone``: the tuck only) the move lowers the hips to
the left with the head kept down (stage A: the pelvis interpolated from knee-chest to its
side-sit pose, the torso held at its knee-chest orientation; contacts knees, toes, hands
and head, then the left hip), then raises the torso about the hip into the side-sit
(stage B: the torso orientation interpolated to the side-sit's). Every keyframe is solved
by placo with its contacts on the floor (the project's ``ContactIk`` robot) and checked
by the static feasibility QP; the move runs under the executor's joint PD at 1× effort
and 0.9× ranges with the static check every 0.1 s (``getup.margins``). A trial ends in
the side-sit when, after 1 s more of holding the last targets, the left hip and both
hands touch the floor, nothing of the torso or upper arms does, and the spine is within
73° of vertical.

    python research/probe_side_sit.py --pose sitting --seeds 0 1 2 3 4 5 6 7 8 9
"""

from __future__ import annotations

import argparse

import mujoco
import numpy as np
import placo
from scipy.spatial.transform import Rotation, Slerp

from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.evaluation.move_margins import move_start
from hybrid_recovery.getup import keyframes, moves
from hybrid_recovery.getup.contact_ik import CONTACT_KEYFRAMES, ContactIk, ContactKeyframe
from hybrid_recovery.getup.contact_ik import _load_points as load_points
from hybrid_recovery.getup.contact_map import floor_contacts
from hybrid_recovery.getup.contacts import FLOOR_CONTACTS
from hybrid_recovery.getup.feasibility import static_feasibility
from hybrid_recovery.getup.margins import margins_along, summarise
from hybrid_recovery.getup.single_move import SingleMove
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import joint_addresses

_KNEES_TOES = ("left_knee", "right_knee", "left_toes", "right_toes")
_HANDS = ("left_hand", "right_hand")
_UPPER = {"back", "chest", "head", "left_shoulder", "right_shoulder", "left_upper_arm",
          "right_upper_arm", "left_elbow", "right_elbow"}


def _rotation(model: mujoco.MjModel, qpos: np.ndarray, body: str) -> Rotation:
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    return Rotation.from_matrix(data.xmat[model.body(body).id].reshape(3, 3))


def _solve(ik: ContactIk, posture: np.ndarray, pelvis: np.ndarray, torso: np.ndarray,
           contacts: tuple[str, ...], hands_xy: dict[str, np.ndarray]) -> np.ndarray:
    """placo IK: contacts on the floor, hands at their xy, pelvis pose and torso
    orientation as soft tasks, the posture as a low-weight joint task; returns qpos."""
    robot = ik.robot
    for name, q in zip(constants.JOINT_NAMES, posture, strict=True):
        robot.set_joint(name, float(q))
    robot.set_T_world_fbase(pelvis)
    robot.update_kinematics()
    points = {name: load_points(robot, name) for name in contacts}
    solver = placo.KinematicsSolver(robot)
    solver.enable_joint_limits(True)
    solver.enable_velocity_limits(False)
    for name in contacts:
        for k in points[name]:
            task = solver.add_position_task(f"{name}_{k}",
                                            np.array([0.0, 0.0, FLOOR_CONTACTS[name].radius]))
            task.mask.set_axises("z")
            task.configure(f"{name}_{k}", "soft", 1e4)
    for name, xy in hands_xy.items():
        task = solver.add_position_task(f"{name}_0", np.array([xy[0], xy[1], 0.0]))
        task.mask.set_axises("xy")
        task.configure(f"{name}_xy", "soft", 1e2)
    solver.add_frame_task("pelvis", pelvis).configure("pelvis", "soft", 10.0, 10.0)
    solver.add_orientation_task("torso_link", torso).configure("torso", "soft", 10.0)
    joints = solver.add_joints_task()
    joints.set_joints({n: float(q) for n, q in zip(constants.JOINT_NAMES, posture, strict=True)})
    joints.configure("posture", "soft", 1.0)
    solver.add_regularization_task(1e-4)
    for _ in range(300):
        solver.solve(True)
        robot.update_kinematics()
    return ik._result(ContactKeyframe(posture, (1.0, 0.0, 0.0, 0.0), contacts), points).qpos


def side_sit_chain(model: mujoco.MjModel) -> list[tuple[str, np.ndarray, tuple[str, ...]]]:
    """The keyframes (name, qpos, contacts): a0.1 … a1.0 (hips down, head down), then
    b0.25 … b1.00 (torso up)."""
    ik = ContactIk(model)
    kc = ik.solve(CONTACT_KEYFRAMES["knee_chest"]).qpos
    ss = ik.solve(CONTACT_KEYFRAMES["side_sit"]).qpos
    # the side-sit turned and shifted so that its hands fall on knee-chest's hand line
    data = mujoco.MjData(model)

    def hands(qpos: np.ndarray) -> np.ndarray:
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        return np.array([data.xpos[model.body(FLOOR_CONTACTS[h].body).id][:2] for h in _HANDS])

    a, b = hands(ss), hands(kc)
    yaw = (np.arctan2(*(b[1] - b[0])[::-1]) - np.arctan2(*(a[1] - a[0])[::-1]))
    turn = Rotation.from_euler("z", yaw)
    aligned = ss.copy()
    aligned[:2] = turn.apply(np.r_[ss[:2] - a.mean(0), 0.0])[:2] + b.mean(0)
    xyzw = (turn * Rotation.from_quat(np.r_[ss[4:7], ss[3]])).as_quat()
    aligned[3:7] = np.r_[xyzw[3], xyzw[:3]]
    hands_xy = dict(zip(_HANDS, hands(kc), strict=True))
    pelvis = Slerp([0, 1], Rotation.concatenate([_rotation(model, kc, "pelvis"),
                                                 _rotation(model, aligned, "pelvis")]))
    chain = []
    for t in np.round(np.arange(0.1, 1.01, 0.1), 2):
        pose = np.eye(4)
        pose[:3, :3] = pelvis(t).as_matrix()
        pose[:3, 3] = (1 - t) * kc[:3] + t * aligned[:3]
        contacts = ((*_KNEES_TOES, *_HANDS, "head") if t < 0.5 else
                    ("left_hip", "left_knee", "right_knee", *_HANDS, "head"))
        qpos = _solve(ik, (1 - t) * kc[7:] + t * aligned[7:], pose,
                      _rotation(model, kc, "torso_link").as_matrix(), contacts, hands_xy)
        chain.append((f"a{t:.1f}", qpos, contacts))
    low = chain[-1][1]
    torso = Slerp([0, 1], Rotation.concatenate([_rotation(model, low, "torso_link"),
                                                _rotation(model, aligned, "torso_link")]))
    pose = np.eye(4)
    pose[:3, :3] = _rotation(model, aligned, "pelvis").as_matrix()
    pose[:3, 3] = aligned[:3]
    for t in (0.25, 0.5, 0.75, 1.0):
        contacts = (("left_hip", "left_knee", "right_knee", *_HANDS) if t < 0.9 else
                    ("left_hip", *_HANDS, "right_foot"))
        qpos = _solve(ik, (1 - t) * low[7:] + t * aligned[7:], pose, torso(t).as_matrix(),
                      contacts, hands_xy)
        chain.append((f"b{t:.2f}", qpos, contacts))
    return chain


def in_side_sit(model: mujoco.MjModel, data: mujoco.MjData) -> bool:
    """Left hip and both hands down, no torso or upper-arm contact, spine_z > 0.3."""
    contacts = set(floor_contacts(model, data)[0])
    spine_z = data.xmat[model.body(constants.TORSO_BODY).id].reshape(3, 3)[2, 2]
    return ({"left_hip", *_HANDS} <= contacts and not contacts & _UPPER
            and spine_z > 0.3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pose", choices=("sitting", "prone"), default="sitting")
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    parser.add_argument("--step", type=float, default=2.0, help="time per keyframe [s]")
    args = parser.parse_args()
    model = load_torque_model()
    robot = RobotModel(model)
    chain = side_sit_chain(model)
    print("keyframe | contacts | statically feasible | ρ")
    for name, qpos, contacts in chain:
        check = static_feasibility(robot, qpos, contacts)
        print(f"{name} | {' '.join(contacts)} | {check.feasible} | {check.worst_ratio:.2f}")
        keyframes.KEYFRAMES[f"side_sit_{name}"] = qpos[7:]  # this process only
    lead = [*moves.MOVES["roll"].phases] if args.pose == "sitting" else []
    phases = (*lead, *moves.MOVES["tuck"].phases,
              *(moves.Phase(f"side_sit_{name}", args.step, 0.5) for name, _, _ in chain))
    moves.ALL_MOVES["probe_side_sit"] = moves.Move("probe_side_sit", args.pose, "other",
                                                   phases)
    reached, rows = 0, []
    for seed in args.seeds:
        data = move_start(model, "lie_back" if args.pose == "sitting" else "tuck", seed)
        single = SingleMove("probe_side_sit")
        samples = margins_along(model, data, single, timeout=120.0)
        target = single.q_ref.copy()
        qadr = joint_addresses(model)[0]
        for _ in range(int(round(1.0 / model.opt.timestep))):
            data.ctrl[:] = pd_torque(target, data.qpos[qadr], data.qvel[qadr - 1])
            mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)
        ok = in_side_sit(model, data)
        reached += ok
        print(f"seed {seed}: {'side-sit' if ok else 'not side-sit'}, contacts "
              f"{floor_contacts(model, data)[0]}")
        rows += summarise([s for s in samples if s.phase.startswith("probe_side_sit/side_sit_")])
    print(f"in side-sit: {reached}/{len(args.seeds)}")
    print("phase | feasible (mean over seeds) | least margin | largest unbalanced wrench | "
          "why not (seeds)")
    for phase in dict.fromkeys(r.phase for r in rows):
        ps = [r for r in rows if r.phase == phase]
        margins = [r.min_margin for r in ps if not np.isnan(r.min_margin)]
        why: dict[str, int] = {}
        for r in ps:
            if r.reason:
                why[r.reason] = why.get(r.reason, 0) + 1
        print(f"{phase.split('/')[1]} | {100 * np.mean([r.feasible_fraction for r in ps]):.0f} % | "
              f"{min(margins) if margins else float('nan'):+.2f} | "
              f"{max(r.max_leftover_force for r in ps):.0f} N, "
              f"{max(r.max_leftover_moment for r in ps):.0f} N·m | "
              + ", ".join(f"{k} ({n})" for k, n in sorted(why.items(), key=lambda kv: -kv[1])))


if __name__ == "__main__":
    main()
