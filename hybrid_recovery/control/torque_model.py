"""A torque-controlled H1-2 for the QP controller: one motor per joint, ``ctrl = τ``.

:func:`hybrid_recovery.robot.mjcf.load_mjmodel` gives PD position servos (``ctrl = q_ref``),
the policy's actuation. The QP controller outputs joint torques, so it runs on the same
robot loaded without those servos and with a direct-drive motor on every joint of
``constants.JOINT_NAMES`` instead: actuator i applies τ_i = ctrl_i [N·m] to joint i,
``ctrlrange = ±EFFORT_LIMITS[i]`` (MuJoCo clamps). Controllers that output torques (the QP
controller, the supervisor with its PD law written out) run on this model::

    model = load_torque_model()          # dt = 0.002 s: the QP runs at 500 Hz
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    controller.reset(model, data)
    data.ctrl[:] = controller(model, data); mujoco.mj_step(model, data)
"""

from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import load_spec

CONTROL_DT = 0.002
"""Physics step = control period of the QP controller [s] (500 Hz)."""


MODEL_MESSAGE = ("BalanceController needs a torque-controlled model (27 motors, ctrl = tau "
                 "in constants.JOINT_NAMES order): build it with load_torque_model()")


def check_torque_model(model: mujoco.MjModel) -> None:
    """Raises ValueError (:data:`MODEL_MESSAGE`) unless actuator i is a unit motor on joint i."""
    if model.nu != constants.NUM_JOINTS:
        raise ValueError(MODEL_MESSAGE)
    for i, name in enumerate(constants.JOINT_NAMES):
        if (model.actuator_trntype[i] != mujoco.mjtTrn.mjTRN_JOINT
                or model.joint(model.actuator_trnid[i, 0]).name != name
                or model.actuator_biastype[i] != mujoco.mjtBias.mjBIAS_NONE
                or model.actuator_gainprm[i, 0] != 1.0 or model.actuator_gear[i, 0] != 1.0):
            raise ValueError(MODEL_MESSAGE)


def torque_spec(path: str | Path | None = None, timestep: float = CONTROL_DT,
                rotor_inertia: bool = False) -> mujoco.MjSpec:
    """The H1-2 spec with a floor and 27 motor actuators in motor order.

    Args:
        path: Robot MJCF; ``None`` for the project's H1-2.
        timestep: Physics step [s].
        rotor_inertia: Give the joints the project's rotor inertia (armature) [kg·m²].

    Returns:
        The spec (extend it, e.g. with sensors, then compile).
    """
    spec = load_spec(path, floor=True, actuators=False, timestep=timestep,
                     rotor_inertia=rotor_inertia)
    for name, tau_max in zip(constants.JOINT_NAMES, constants.EFFORT_LIMITS, strict=True):
        motor = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        motor.set_to_motor()
        motor.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        motor.ctrlrange = [-float(tau_max), float(tau_max)]
    return spec


def torque_twin(servo_model: mujoco.MjModel) -> mujoco.MjModel:
    """The torque-controlled twin of a PD-servo model: same robot, bodies, geoms and sites;
    actuator i is a unit motor on joint i with ``ctrlrange = ±EFFORT_LIMITS[i]``.

    A torque controller then runs on the twin while the servo model is simulated:
    τ becomes the servo target q_ref = q + (τ + K_D q̇) / K_P (:func:`servo_target`).

    Raises:
        ValueError: ``servo_model`` does not have one actuator per joint in motor order.
    """
    twin = copy.copy(servo_model)
    if twin.nu != constants.NUM_JOINTS:
        raise ValueError(MODEL_MESSAGE)
    twin.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    twin.actuator_gainprm[:] = 0.0
    twin.actuator_gainprm[:, 0] = 1.0
    twin.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
    twin.actuator_biasprm[:] = 0.0
    twin.actuator_ctrllimited[:] = 1
    twin.actuator_ctrlrange[:] = np.stack([-constants.EFFORT_LIMITS, constants.EFFORT_LIMITS], 1)
    check_torque_model(twin)
    return twin


def servo_target(torque: np.ndarray, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """q_ref (27,) [rad] for which the PD servos τ = K_P (q_ref − q) − K_D q̇ apply
    ``torque`` (27,) [N·m] (the servos clip at the same ±τ_max)."""
    return q + (torque + constants.KD * qd) / constants.KP


def load_torque_model(path: str | Path | None = None, timestep: float = CONTROL_DT,
                      rotor_inertia: bool = False) -> mujoco.MjModel:
    """Compiles :func:`torque_spec`: ``ctrl`` = joint torques τ (27,) [N·m], motor order."""
    return torque_spec(path, timestep, rotor_inertia).compile()
