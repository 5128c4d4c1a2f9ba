"""Loading the H1-2 MJCF into MuJoCo with the project's floor and PD position actuators.

The robot file carries bodies, inertias, joints, collision primitives and sites only; the
floor and the actuators are added here with ``mujoco.MjSpec`` so that gains and limits
come from :mod:`hybrid_recovery.robot.constants` alone. Any H1-2 MJCF with the joint
names of ``constants.JOINT_NAMES`` loads (ours, or the manufacturer's, whose meshes are
resolved relative to its own directory).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.robot import constants
from hybrid_recovery.robot.conform import conform_spec

H1_2_MJCF: Path = Path(__file__).resolve().parents[2] / "models" / "h1_2" / "h1_2.xml"
"""The project's own H1-2 MJCF, ``models/h1_2/h1_2.xml`` at the repository top level.

Resolved relative to this source file, which assumes the package is installed editable
(``pip install -e .``) or run from a checkout.
"""

FLOOR_NAME = "floor"
"""Name of the ground plane geom (contype 0, conaffinity 1: robot geoms hit only it)."""


def load_spec(
    path: str | Path | None = None,
    *,
    floor: bool = True,
    actuators: bool = True,
    timestep: float | None = None,
    rotor_inertia: bool = False,
) -> mujoco.MjSpec:
    """Parses an H1-2 MJCF with a floor and one PD position actuator per joint.

    Actuator ``i`` drives ``constants.JOINT_NAMES[i]`` whatever the file's joint order:
    τ_i = k_p,i (q_ref,i − q_i) − k_d,i q̇_i with ``ctrl = q_ref`` [rad], clipped to
    ±``EFFORT_LIMITS[i]`` [N·m]; the control range is unlimited. Actuators declared in
    the file are removed, so ``model.nu`` is 27 with actuators and 0 without.

    Args:
        path: MJCF file; ``None`` for the project's model :data:`H1_2_MJCF`.
        floor: Add a ground plane named ``floor`` (z = 0) if the file has no geom of
            that name.
        actuators: Add the 27 position actuators.
        timestep: Simulation timestep [s]; ``None`` keeps the file's.
        rotor_inertia: Give every joint the project's model's armature [kg·m²] (for a
            file without rotor inertia, such as the manufacturer's).

    Returns:
        The model's spec, ready to extend (e.g. with sensors) or compile.

    Raises:
        FileNotFoundError: The file does not exist.
        ValueError: The file is not valid MJCF, a joint of ``constants.JOINT_NAMES``
            is not in it, or its first joint is not the floating base's free joint (the
            message names the file).
    """
    path = H1_2_MJCF if path is None else Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"H1-2 MJCF not found: {path}")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except ValueError as err:  # MuJoCo's XML error does not name the file
        raise ValueError(f"cannot parse H1-2 MJCF {path}: {err}") from None
    joint_names = {joint.name for joint in spec.joints}
    for name in constants.JOINT_NAMES:
        if name not in joint_names:
            raise ValueError(f"H1-2 MJCF {path} has no joint named '{name}'")
    if spec.joints[0].type != mujoco.mjtJoint.mjJNT_FREE:  # qpos[0:7] is the floating base
        raise ValueError(f"H1-2 MJCF {path} has no free joint before its other joints: the "
                         "floating base needs one (<freejoint/> in the pelvis body)")

    if timestep is not None:
        spec.option.timestep = timestep
    if floor and spec.geom(FLOOR_NAME) is None:
        _add_floor(spec)
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    if actuators:
        _add_position_actuators(spec)
    conform_spec(spec, FLOOR_NAME, rotor_inertia)
    return spec


def load_mjmodel(
    path: str | Path | None = None,
    *,
    floor: bool = True,
    actuators: bool = True,
    timestep: float | None = None,
    rotor_inertia: bool = False,
) -> mujoco.MjModel:
    """Compiles :func:`load_spec` (see there for the arguments and errors).

    Raises:
        ValueError: Also when MuJoCo cannot compile the file (the message names it).
    """
    spec = load_spec(path, floor=floor, actuators=actuators, timestep=timestep,
                     rotor_inertia=rotor_inertia)
    try:
        return spec.compile()
    except ValueError as err:
        raise ValueError(f"cannot compile H1-2 MJCF {path or H1_2_MJCF}: {err}") from None


def default_qpos(model: mujoco.MjModel) -> np.ndarray:
    """The standing state q*: base at (0, 0, h*), identity orientation, joints at q*.

    Joint values are written at the model's own qpos addresses, so any H1-2 model with
    the names of ``constants.JOINT_NAMES`` works.

    Args:
        model: An H1-2 model whose first joint is the free floating-base joint.

    Returns:
        qpos of shape (model.nq,): position [m], quaternion (w, x, y, z), joints [rad].
    """
    qpos = model.qpos0.copy()
    base = model.jnt_qposadr[0]
    qpos[base : base + 3] = (0.0, 0.0, constants.DEFAULT_BASE_HEIGHT)
    qpos[base + 3 : base + 7] = (1.0, 0.0, 0.0, 0.0)
    for name, value in zip(constants.JOINT_NAMES, constants.DEFAULT_JOINT_POS, strict=True):
        qpos[model.jnt_qposadr[model.joint(name).id]] = value
    return qpos


def joint_addresses(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """The qpos and qvel addresses of the 27 actuated joints, in ``constants.JOINT_NAMES``
    (motor) order, looked up by name (any H1-2 model): (qadr (27,), dadr (27,)) int."""
    joints = [model.joint(name) for name in constants.JOINT_NAMES]
    return (np.array([j.qposadr[0] for j in joints]), np.array([j.dofadr[0] for j in joints]))


def _add_floor(spec: mujoco.MjSpec) -> None:
    """Adds the infinite ground plane z = 0 (collides with robot geoms, not itself)."""
    spec.worldbody.add_geom(
        name=FLOOR_NAME,
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 0.05],
        contype=0,
        conaffinity=1,
        condim=3,
        rgba=[0.35, 0.4, 0.45, 1.0],
    )


def _add_position_actuators(spec: mujoco.MjSpec) -> None:
    """Adds actuator i = PD position servo on JOINT_NAMES[i] with KP[i], KD[i], ±τ_max.

    The actuator's force range is the one effort limit: a joint ``actuatorfrcrange`` from
    the file is switched off, or it would clamp again whatever the actuator's range is
    set to (the torque curriculum scales the actuators' ranges per simulation).
    """
    for name, kp, kd, tau_max in zip(
        constants.JOINT_NAMES,
        constants.KP,
        constants.KD,
        constants.EFFORT_LIMITS,
        strict=True,
    ):
        actuator = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        actuator.set_to_position(kp=float(kp), kv=float(kd))
        actuator.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
        actuator.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        actuator.forcerange = [-float(tau_max), float(tau_max)]
        spec.joint(name).actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
