"""What the MDP reads at each control step: the balance quantities (paper §III-E) and the
proprioception (§III-C) from the simulation's arrays, the reward terms' inputs, and the
critic's privileged balance observation (§III-D).

Pure functions in the array API standard: the environment calls them with numpy arrays
(CPU MuJoCo, float64) and the same functions take torch tensors on any device (float32
MuJoCo Warp arrays seen through ``wp.to_torch``), so the terms are written once.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from array_api_compat import array_namespace

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.dynamics.arrays import Array
from hybrid_recovery.dynamics.capturability import capture_point
from hybrid_recovery.dynamics.centroidal import net_centroidal_wrench
from hybrid_recovery.dynamics.support import signed_distance_batched
from hybrid_recovery.envs.rewards import RewardState
from hybrid_recovery.observation.actor import projected_gravity
from hybrid_recovery.sim.scene import SensorLayout, read_contacts

PRIVILEGED_DIM = 17
"""CoM position (3), velocity (3), acceleration (3), p_l (3), L (3), ξ − p_c,xy (2)."""

CONTACT_FORCE_MIN = 1.0
"""Normal force [N] above which a contact slot counts as bearing load."""
SOFT_LIMIT = 0.95
"""Share of each joint's half range inside which the joint-limit term is 0."""


@dataclass(frozen=True)
class StepIndices:
    """Where the step's quantities sit in the simulation's arrays.

    Attributes:
        layout: the scene's sensor layout (CoM, momenta, IMU, contact slots).
        foot_slots: contact slots of the left and right foot.
        support_slots: contact slots of the hands and elbows.
        torso_slots: contact slots of the torso.
        feet: body ids of the feet (left, right); knees: of the knee links.
        qadr: qpos addresses of the 27 joints; dadr: their qvel addresses.
    """

    layout: SensorLayout
    foot_slots: tuple[np.ndarray, np.ndarray]
    support_slots: np.ndarray
    torso_slots: np.ndarray
    feet: np.ndarray
    knees: np.ndarray
    qadr: np.ndarray
    dadr: np.ndarray

    @property
    def feet_slots(self) -> np.ndarray:
        return np.concatenate(self.foot_slots)


def read_step_state(sensordata: Array, xmat: Array, qpos: Array, qvel: Array,
                    actuator_force: Array, mass: Array, prev_momentum: Array,
                    prev_com_vel: Array, at: StepIndices, dt: float,
                    ground: Array | None = None) -> dict[str, Array]:
    """The step's quantities of N envs, from their simulation arrays.

    Args:
        sensordata: (N, nsensordata); xmat: body rotations (N, nbody, 9);
        qpos: (N, nq); qvel: (N, nv); actuator_force: τ (N, 27) [N·m].
        mass: each env's robot mass m (N,) [kg].
        prev_momentum: [p_l; L] of the previous step (N, 6); prev_com_vel: ċ (N, 3).
        dt: the control step Δt [s] of the finite differences.
        ground: the ground's height under each CoM (N,) [m]; None: z = 0 (flat ground).

    Returns:
        {name: array}: mass, com c (N, 3), com_vel ċ, com_acc c̈ (finite difference),
        lin p_l = m ċ, ang L (about the CoM), momentum [p_l; L] (N, 6), cp ξ (N, 2),
        height h_c (above the ground) and height_vel ḣ_c (N,), net_force F_net and
        net_torque τ_net (N, 3),
        d_com (to the hull of all contacts) and d_cp (to the feet's) (N,) [m],
        torso_force, support_contacts (N,), foot_force (N, 2) [N], foot_up and shin_up
        (z of each sole's / shin's axis, N, 2), gyro (N, 3), quat (N, 4), gravity_b
        (N, 3), q, dq (N, 27), torque (N, 27).
    """
    xp = array_namespace(sensordata, qpos)
    lay = at.layout
    com, vel = sensordata[:, lay.com], sensordata[:, lay.com_linvel]
    lin, ang = mass[:, None] * vel, sensordata[:, lay.com_angmom]
    force, torque = net_centroidal_wrench(lin, ang, prev_momentum[:, :3], prev_momentum[:, 3:], dt)
    height = com[:, 2] if ground is None else com[:, 2] - ground
    cp = capture_point(com[:, :2], vel[:, :2], xp.maximum(height, 1e-3), g=GRAVITY)
    active, normal, points = read_contacts(sensordata, lay)
    active = active & (normal > CONTACT_FORCE_MIN)
    feet = at.feet_slots
    quat = sensordata[:, lay.quat]
    return dict(
        mass=mass, com=com, com_vel=vel, com_acc=(vel - prev_com_vel) / dt, lin=lin, ang=ang,
        momentum=xp.concat([lin, ang], axis=1), cp=cp, height=height,
        height_vel=vel[:, 2], net_force=force, net_torque=torque,
        d_com=signed_distance_batched(com[:, :2], points, active),
        d_cp=signed_distance_batched(cp, points[:, feet], active[:, feet]),
        torso_force=xp.sum(normal[:, at.torso_slots], axis=1),
        support_contacts=xp.sum(xp.astype(active[:, at.support_slots], com.dtype), axis=1),
        foot_force=xp.stack([xp.sum((normal * active)[:, slots], axis=1)
                             for slots in at.foot_slots], axis=1),
        foot_up=xmat[:, at.feet, 8], shin_up=xmat[:, at.knees, 8],
        gyro=sensordata[:, lay.gyro], quat=quat, gravity_b=projected_gravity(quat),
        q=qpos[:, at.qadr], dq=qvel[:, at.dadr], torque=actuator_force,
    )


def reward_state(s: Mapping[str, Array], joint_range: Array, velocity_limit: Array,
                 action: Array, last_action: Array, terminated: Array) -> RewardState[Array]:
    """The reward terms' inputs (:class:`~hybrid_recovery.envs.rewards.RewardState`).

    Args:
        s: :func:`read_step_state`'s quantities.
        joint_range: this episode's joint ranges (N, 27, 2) [rad].
        velocity_limit: the joints' velocity limits ω_max (27,) [rad/s].
        action: a_t and last_action: a_{t−1}, (N, 27).
        terminated: early terminations of this step (N,) bool.
    """
    xp = array_namespace(s["q"], joint_range)
    lo, hi = joint_range[..., 0], joint_range[..., 1]
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * SOFT_LIMIT
    excess = xp.sum(xp.maximum(xp.abs(s["q"] - mid) - half, 0.0), axis=1)
    too_fast = xp.sum(xp.maximum(xp.abs(s["dq"]) / velocity_limit - 1.0, 0.0), axis=1)
    return RewardState(
        height=s["height"], height_vel=s["height_vel"], com_distance=s["d_com"],
        cp_distance=s["d_cp"], net_force=s["net_force"], net_torque=s["net_torque"],
        torque=s["torque"], limit_violation=excess, speed_violation=too_fast,
        action=action, last_action=last_action,
        gravity_b=s["gravity_b"], support_contacts=s["support_contacts"],
        foot_force=s["foot_force"], foot_up=s["foot_up"], weight=s["mass"] * GRAVITY,
        terminated=terminated,
    )


def privileged_observation(s: Mapping[str, Array], base_xy: Array) -> Array:
    """The critic's balance quantities in the heading frame (yaw of the IMU), (N, 17):
    CoM relative to the base horizontally and above the ground (3), ċ (3), c̈ (3), p_l (3),
    L (3), ξ − c_xy (2).

    Args:
        s: :func:`read_step_state`'s quantities.
        base_xy: the floating base's horizontal position (N, 2) [m].
    """
    xp = array_namespace(s["quat"], base_xy)
    w, x, y, z = (s["quat"][:, i] for i in range(4))
    yaw = xp.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    c, si = xp.cos(yaw)[:, None], xp.sin(yaw)[:, None]

    def heading(v: Array) -> Array:
        vx, vy = v[:, 0:1], v[:, 1:2]
        return xp.concat([c * vx + si * vy, -si * vx + c * vy, v[:, 2:]], axis=1)

    com = s["com"]
    rel = xp.concat([com[:, :2] - base_xy, s["height"][:, None]], axis=1)
    cp_rel = s["cp"] - com[:, :2]
    return xp.concat([heading(rel), heading(s["com_vel"]), heading(s["com_acc"]),
                      heading(s["lin"]), heading(s["ang"]), heading(cp_rel)], axis=1)
