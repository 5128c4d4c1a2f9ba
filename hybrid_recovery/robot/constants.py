"""Unitree H1-2 constants: the single source of truth for joint order, pose, gains and limits.

Every other module (MJCF actuators, Pinocchio model, environment, deployment) reads the
robot's joint order, default pose, PD gains, effort limits and index maps from here.

Joint order is the robot's motor order (27 actuated joints), which is also the order of
the joints in the project's MJCF and in Pinocchio's ``q[7:]``:
left leg (0–5), right leg (6–11), waist yaw (12), left arm (13–19), right arm (20–26).
"""

from __future__ import annotations

import numpy as np

NUM_JOINTS = 27
"""Number of actuated joints (the floating base excluded)."""

JOINT_NAMES: tuple[str, ...] = (
    "left_hip_yaw_joint",
    "left_hip_pitch_joint",
    "left_hip_roll_joint",
    "left_knee_joint",
    "left_ankle_pitch_joint",
    "left_ankle_roll_joint",
    "right_hip_yaw_joint",
    "right_hip_pitch_joint",
    "right_hip_roll_joint",
    "right_knee_joint",
    "right_ankle_pitch_joint",
    "right_ankle_roll_joint",
    "torso_joint",
    "left_shoulder_pitch_joint",
    "left_shoulder_roll_joint",
    "left_shoulder_yaw_joint",
    "left_elbow_joint",
    "left_wrist_roll_joint",
    "left_wrist_pitch_joint",
    "left_wrist_yaw_joint",
    "right_shoulder_pitch_joint",
    "right_shoulder_roll_joint",
    "right_shoulder_yaw_joint",
    "right_elbow_joint",
    "right_wrist_roll_joint",
    "right_wrist_pitch_joint",
    "right_wrist_yaw_joint",
)
"""Actuated joints in motor order (= MJCF order = Pinocchio order)."""

TOTAL_MASS = 66.984
"""Total mass of the H1-2 without hands [kg] (manufacturer's description)."""

_LEG_EFFORT = (200.0, 200.0, 200.0, 300.0, 60.0, 40.0)
_ARM_EFFORT = (40.0, 40.0, 18.0, 18.0, 19.0, 19.0, 19.0)
EFFORT_LIMITS = np.array(_LEG_EFFORT * 2 + (200.0,) + _ARM_EFFORT * 2)
"""Hardware effort limits τ_max per joint [N·m], shape (27,)."""

_LEG_VELOCITY = (23.0, 23.0, 23.0, 14.0, 9.0, 9.0)
_ARM_VELOCITY = (9.0, 9.0, 20.0, 20.0, 31.4, 31.4, 31.4)
VELOCITY_LIMITS = np.array(_LEG_VELOCITY * 2 + (23.0,) + _ARM_VELOCITY * 2)
"""Manufacturer's joint velocity limits ω_max per joint [rad/s], shape (27,): the
``<limit velocity=...>`` of each joint in Unitree's ``h1_2_handless.urdf`` (hips and
waist 23, knees 14, ankles 9, shoulder pitch/roll 9, shoulder yaw and elbow 20, wrists
31.4). The DC motor model (:mod:`hybrid_recovery.robot.actuator`) reads them."""

_LEG_KP = (200.0, 300.0, 200.0, 600.0, 600.0, 150.0)
_LEG_KD = (5.0, 5.0, 5.0, 8.0, 6.0, 4.0)
_ARM_KP = (120.0, 120.0, 80.0, 80.0, 40.0, 40.0, 40.0)
_ARM_KD = (2.0, 2.0, 2.0, 2.0, 1.0, 1.0, 1.0)
KP = np.array(_LEG_KP * 2 + (300.0,) + _ARM_KP * 2)
"""PD stiffness k_p per joint [N·m/rad], shape (27,).

Legs (hip yaw, pitch, roll, knee, ankle pitch, roll) = (200, 300, 200, 600, 600, 150),
stiffer than the published walking gains (200, 200, 200, 300, 40, 40) so that the robot
stands at the default pose under its own PD, with no controller (10 s test). A passive
PD stance is an inverted pendulum: linearised about the stance it is stable only if the
joint stiffness beats gravity's negative stiffness, K − G ≻ 0. Sagittally the ankles
must carry roughly m g h_c ≈ 67 kg · 9.81 · 0.86 m ≈ 560 N·m/rad (> 280 per ankle)
plus margin for the knee and hip compliance in series; laterally (parallelogram sway)
k_hip_roll + k_ankle_roll per leg must exceed ≈ 280. With the published gains both
modes are unstable (eigenvalues +2.8 s⁻¹ and +0.7 s⁻¹: the robot falls in ≈ 1.4 s).
The knee carries ≈ 27 N·m of gravity load in the bent default pose; 600 keeps the sag
to ≈ 0.045 rad (torso tilt ≈ 4.5° at rest). Waist and arms: published values. The
effort limits (ankle pitch 60 N·m) still clip the torque.
"""
KD = np.array(_LEG_KD * 2 + (5.0,) + _ARM_KD * 2)
"""PD damping k_d per joint [N·m·s/rad], shape (27,).

Legs (5, 5, 5, 8, 6, 4): the published walking damping (2.5, 2.5, 2.5, 4, 2, 2) doubled
at the hips and knee and tripled/doubled at the ankles, with their stiffer k_p.
"""

_LEG_POSE = (0.0, -0.16, 0.0, 0.36, -0.2, 0.0)
_LEFT_ARM_POSE = (0.2, 0.2, 0.0, 0.6, 0.0, 0.0, 0.0)
_RIGHT_ARM_POSE = (0.2, -0.2, 0.0, 0.6, 0.0, 0.0, 0.0)
DEFAULT_JOINT_POS = np.array(_LEG_POSE * 2 + (0.0,) + _LEFT_ARM_POSE + _RIGHT_ARM_POSE)
"""Default standing pose q* [rad], shape (27,): the action origin of the policy."""

UPRIGHT_COM_HEIGHT = 0.85
"""CoM height h_c above which the robot counts as up [m]: the paper's success criterion
(arXiv 2603.08619, Sec. IV), the environment's stuck-low and success checks, the
evaluation, sim-to-sim and the supervisor's hand-back to the QP."""

DEFAULT_BASE_HEIGHT = 1.015
"""Pelvis height above the ground in the default standing pose [m] (feet flat).

The soles (0.045 m below the ankle roll axis) touch z = 0 at 1.0151 m in the default leg
pose (hip 0.1632 + thighs 0.4 cos 0.16 + shins 0.4 cos 0.2 + 0.02 + 0.045).
"""

IMU_BODY = "torso_link"
"""The robot's IMU sits on the torso link, not on the pelvis."""

FOOT_BODIES: tuple[str, str] = ("left_ankle_roll_link", "right_ankle_roll_link")
"""Bodies carrying the foot soles (left, right)."""

KNEE_BODIES: tuple[str, str] = ("left_knee_link", "right_knee_link")
"""The shins (left, right): each link's z axis runs from its ankle up to its knee."""

TORSO_BODY = "torso_link"
PELVIS_BODY = "pelvis"

MIRROR_JOINT_INDEX = np.array(
    [6, 7, 8, 9, 10, 11, 0, 1, 2, 3, 4, 5, 12]
    + list(range(20, 27))
    + list(range(13, 20))
)
"""Index map of the left/right mirror: ``q_mirror = MIRROR_SIGN * q[MIRROR_JOINT_INDEX]``."""

_LEG_SIGN = (-1.0, 1.0, -1.0, 1.0, 1.0, -1.0)
_ARM_SIGN = (1.0, -1.0, -1.0, 1.0, -1.0, 1.0, -1.0)
MIRROR_SIGN = np.array(_LEG_SIGN * 2 + (-1.0,) + _ARM_SIGN * 2)
"""Sign flips of the left/right mirror (yaw and roll axes flip), shape (27,)."""

for _name, _arr in (
    ("EFFORT_LIMITS", EFFORT_LIMITS),
    ("VELOCITY_LIMITS", VELOCITY_LIMITS),
    ("KP", KP),
    ("KD", KD),
    ("DEFAULT_JOINT_POS", DEFAULT_JOINT_POS),
    ("MIRROR_SIGN", MIRROR_SIGN),
):
    assert _arr.shape == (NUM_JOINTS,), f"{_name} must have shape ({NUM_JOINTS},)"
    _arr.setflags(write=False)
