"""Where the QP's model holds: the measurements the hybrid supervisor checks before it hands
the robot to the QP (:class:`~hybrid_recovery.control.supervisor.HybridSupervisor`).

The QP assumes gravity along the contact normal (ground plane z = 0), the model's mass m
and that the motors apply the torque τ it commands. Each assumption has one measurement:

* ground tilt θ = max over the foot contacts of ∠(n, −ĝ) [rad], n the contact normal, ĝ
  the direction of gravity (on the robot: the IMU's);
* weight ratio ρ = Σ F_z / (m g), the vertical ground reaction over the model's weight
  (a robot standing still: ρ = 1 with the right mass);
* torque error e = max_i |τ_applied,i − τ_cmd,i| / τ_lim,i, the motors' applied torque
  against the command of the step before, clipped to the model's ±τ_lim (weak motors,
  an actuation delay or a torque–speed curve show as e > 0).
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.dynamics.robot_model import GRAVITY
from hybrid_recovery.robot import constants


def foot_body_ids(model: mujoco.MjModel) -> np.ndarray:
    """Body ids of the two feet (:data:`~hybrid_recovery.robot.constants.FOOT_BODIES`), (2,)."""
    return np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
                     for name in constants.FOOT_BODIES])


def ground_tilt(model: mujoco.MjModel, data: mujoco.MjData, feet: np.ndarray) -> float:
    """θ [rad]: the largest angle between a foot contact's normal and the direction of
    gravity (``model.opt.gravity``); 0 without foot contact.

    Args:
        feet: the feet's body ids (:func:`foot_body_ids`), (2,).
    """
    down = model.opt.gravity / np.linalg.norm(model.opt.gravity)
    tilt = 0.0
    for contact in data.contact[:data.ncon]:
        if np.isin(model.geom_bodyid[contact.geom], feet).any():
            cosine = min(1.0, abs(float(contact.frame[:3] @ down)))
            tilt = max(tilt, float(np.arccos(cosine)))
    return tilt


def weight_ratio(model: mujoco.MjModel, data: mujoco.MjData, mass: float) -> float:
    """ρ = Σ F_z / (m g): the vertical force of the ground (world body 0) on the robot over
    the weight of ``mass`` [kg]."""
    force, vertical = np.zeros(6), 0.0
    for i, contact in enumerate(data.contact[:data.ncon]):
        bodies = model.geom_bodyid[contact.geom]
        if (bodies == 0).sum() != 1:
            continue
        mujoco.mj_contactForce(model, data, i, force)
        vertical += abs(float(contact.frame.reshape(3, 3).T[2] @ force[:3]))
    return vertical / (mass * GRAVITY)


def torque_error(applied: np.ndarray, commanded: np.ndarray) -> float:
    """e = max_i |τ_applied,i − clip(τ_cmd,i, ±τ_lim,i)| / τ_lim,i; both (27,) [N·m]."""
    limit = constants.EFFORT_LIMITS
    return float(np.max(np.abs(applied - np.clip(commanded, -limit, limit)) / limit))
