"""The training scene: the robot, the floor, actuators and the sensors the MDP reads.

Sensors are computed by MuJoCo inside each physics step (in C, on all threads), so the
environment reads its balance inputs from ``sensordata`` without a Python loop:

* ``imu_gyro`` (3), ``imu_quat`` (4): the torso IMU, as on the robot;
* ``com`` / ``com_linvel`` / ``com_angmom`` (3 each): subtree CoM, CoM velocity and
  angular momentum about the CoM of the root body (checked equal to
  :class:`hybrid_recovery.dynamics.RobotModel` in the tests);
* one ``contact`` sensor per contact group target, data ``found force pos``: the number
  of contacts with the floor, then per slot the contact force (normal first) and the
  contact point (world) — the support hulls come from these actual contacts.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from array_api_compat import array_namespace, device

from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import FLOOR_NAME, load_spec
from hybrid_recovery.sim.terrain import Terrain
from hybrid_recovery.sim.terrain_model import add_terrain_slots

CONTACT_GROUPS: dict[str, tuple[tuple[str, str, int], ...]] = {
    # group: ((kind, target, slots), ...); kind "body" matches all geoms of the body.
    "left_foot": (("body", "left_ankle_roll_link", 4),),
    "right_foot": (("body", "right_ankle_roll_link", 4),),
    "knees": (("body", "left_knee_link", 2), ("body", "right_knee_link", 2)),
    "thighs": (("body", "left_hip_roll_link", 1), ("body", "right_hip_roll_link", 1)),
    "pelvis": (("body", "pelvis", 2),),
    "hands": (("body", "left_wrist_yaw_link", 1), ("body", "right_wrist_yaw_link", 1)),
    "elbows": (("body", "left_elbow_link", 1), ("body", "right_elbow_link", 1),
               ("body", "left_wrist_roll_link", 1), ("body", "right_wrist_roll_link", 1)),
    "upper_arms": (("body", "left_shoulder_yaw_link", 1), ("body", "right_shoulder_yaw_link", 1)),
    "torso": (("body", "torso_link", 2),),
}
"""Contact groups → contact-sensor targets and the contact slots each keeps."""

_CONTACT_WIDTH = 7  # found (1) + force (3) + pos (3) per slot
_CONTACT_DATA = 1 | 2 | 16  # mjtConDataType bits: found, force, pos


@dataclass(frozen=True)
class SensorLayout:
    """Where each quantity sits in ``sensordata`` and in the contact slot arrays."""

    gyro: slice
    quat: slice
    com: slice
    com_linvel: slice
    com_angmom: slice
    contact_adr: np.ndarray
    """sensordata address of each contact slot's block, shape (M,)."""
    contact_slot: np.ndarray
    """Slot index within its sensor (active iff slot < found), shape (M,)."""
    contact_found_adr: np.ndarray
    """sensordata address of the slot's sensor's ``found`` count, shape (M,)."""
    group_slots: dict[str, np.ndarray]
    """Contact group → indices into the M slots."""


def build_scene(path: str | Path | None = None, timestep: float = 0.005,
                delay_samples: int = 0, rotor_inertia: bool = False,
                rough: tuple[Terrain, ...] = (), step_height: float = 0.0):
    """Compiles the robot with floor, actuators and the MDP's sensors.

    Args:
        path: Robot MJCF; None for the project's H1-2.
        timestep: Physics step [s].
        delay_samples: If > 0, each actuator keeps this many past controls (one per
            substep) and applies ``ctrl`` ``actuator_delay`` seconds late, held
            piecewise constant (MuJoCo's native actuator delay); the delay itself is
            set per simulation.
        rotor_inertia: Give the joints the project's rotor inertia (armature) [kg·m²],
            for a file without it (see :func:`hybrid_recovery.robot.mjcf.load_spec`).
        rough, step_height: with a ``step_height`` > 0 [m], the terrain slots of
            :func:`~hybrid_recovery.sim.terrain_model.add_terrain_slots`; none otherwise.

    Returns:
        (model, layout): the compiled ``mujoco.MjModel`` and its :class:`SensorLayout`.
    """
    spec = load_spec(path, floor=True, actuators=True, timestep=timestep,
                     rotor_inertia=rotor_inertia)
    if step_height > 0:
        add_terrain_slots(spec, rough, step_height)
    if delay_samples > 0:
        for actuator in spec.actuators:
            actuator.nsample, actuator.interp, actuator.delay = delay_samples, 0, 0.0
    site, body = mujoco.mjtObj.mjOBJ_SITE, mujoco.mjtObj.mjOBJ_BODY
    root = constants.PELVIS_BODY
    plain = (
        ("imu_gyro", mujoco.mjtSensor.mjSENS_GYRO, site, "imu"),
        ("imu_quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT, site, "imu"),
        ("com", mujoco.mjtSensor.mjSENS_SUBTREECOM, body, root),
        ("com_linvel", mujoco.mjtSensor.mjSENS_SUBTREELINVEL, body, root),
        ("com_angmom", mujoco.mjtSensor.mjSENS_SUBTREEANGMOM, body, root),
    )
    for name, kind, objtype, objname in plain:
        spec.add_sensor(name=name, type=kind, objtype=objtype, objname=objname)
    contact_names: list[tuple[str, str, int]] = []
    for group, targets in CONTACT_GROUPS.items():
        for kind, target, slots in targets:
            name = f"contact_{target}"
            objtype = body if kind == "body" else mujoco.mjtObj.mjOBJ_GEOM
            spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=objtype,
                            objname=target, reftype=mujoco.mjtObj.mjOBJ_GEOM, refname=FLOOR_NAME,
                            intprm=[_CONTACT_DATA, 0, slots])
            contact_names.append((group, name, slots))
    model = spec.compile()

    def span(name: str) -> slice:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
        adr = int(model.sensor_adr[sid])
        return slice(adr, adr + int(model.sensor_dim[sid]))

    adr: list[int] = []
    slot: list[int] = []
    found: list[int] = []
    groups: dict[str, list[int]] = {}
    for group, name, slots in contact_names:
        start = span(name).start
        first = len(adr)
        for k in range(slots):
            adr.append(start + k * _CONTACT_WIDTH)
            slot.append(k)
            found.append(start)
        groups.setdefault(group, []).extend(range(first, first + slots))
    layout = SensorLayout(
        gyro=span("imu_gyro"), quat=span("imu_quat"), com=span("com"),
        com_linvel=span("com_linvel"), com_angmom=span("com_angmom"),
        contact_adr=np.array(adr), contact_slot=np.array(slot),
        contact_found_adr=np.array(found),
        group_slots={g: np.array(v) for g, v in groups.items()},
    )
    return model, layout


def read_contacts(sensordata: Array, layout: SensorLayout) -> tuple[Array, Array, Array]:
    """Active contact slots, their normal forces and points, from sensordata (a numpy
    array or a torch tensor).

    Args:
        sensordata: shape (N, nsensordata).
        layout: the scene's :class:`SensorLayout`.

    Returns:
        (active (N, M) bool, normal_force (N, M) [N], points (N, M, 3) [m]).
    """
    xp = array_namespace(sensordata)
    found = sensordata[:, layout.contact_found_adr]
    active = xp.asarray(layout.contact_slot, device=device(sensordata))[None, :] < found
    normal = sensordata[:, layout.contact_adr + 1] * active
    idx = layout.contact_adr[:, None] + np.arange(4, 7)[None, :]
    points = sensordata[:, idx]
    return active, normal, points
