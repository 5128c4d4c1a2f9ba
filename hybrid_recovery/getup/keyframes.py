"""Joint keyframes of the ground moves: PD targets q_ref (27,) [rad], motor order.

Written left side first; the right side is the left–right mirror (``constants.MIRROR_*``)
unless a keyframe is asymmetric on purpose (the roll). Targets are clamped to the joint
ranges × 0.9 when executed (:mod:`hybrid_recovery.getup.moves`).
"""

from __future__ import annotations

import numpy as np

from hybrid_recovery.robot import constants


def _symmetric(leg: tuple[float, ...], waist: float, arm: tuple[float, ...]) -> np.ndarray:
    """q from the left leg (hip yaw, pitch, roll, knee, ankle pitch, roll), the waist yaw
    and the left arm (shoulder pitch, roll, yaw, elbow, wrist roll, pitch, yaw)."""
    left = np.zeros(constants.NUM_JOINTS)
    left[0:6], left[12], left[13:20] = leg, waist, arm
    mirrored = constants.MIRROR_SIGN * left[constants.MIRROR_JOINT_INDEX]
    out = left.copy()
    out[6:12], out[20:27] = mirrored[6:12], mirrored[20:27]
    return out


def mirror(q: np.ndarray) -> np.ndarray:
    """The left–right mirror image of joint targets q (27,) [rad]."""
    return constants.MIRROR_SIGN * np.asarray(q)[constants.MIRROR_JOINT_INDEX]


SUPINE_REST = _symmetric((0.0, -0.1, 0.0, 0.2, 0.0, 0.0), 0.0, (0.0, 0.2, 0.0, 0.3, 0, 0, 0))
"""Lying on the back, limbs at rest (the end of the lie-back from sitting)."""

TUCK = _symmetric((0.0, -1.5, 0.0, 1.8, 0.0, 0.0), 0.0, (0.0, 0.2, 0.0, 0.3, 0, 0, 0))
"""On the back with hips and knees flexed: a compact lower body for the roll."""


def _roll(waist: float) -> np.ndarray:
    q = TUCK.copy()
    q[12] = waist
    q[13], q[14] = 0.0, 1.5      # left arm out to the side, under the roll
    q[20], q[21] = -1.5, -0.2    # right arm forward, over the chest
    return q


ROLL_TWIST = _roll(2.0)
"""The roll to the left: waist yawed 2 rad carries the torso over its left side, the
right arm swings across, the tucked legs follow."""

ROLL_UNWIND = _roll(0.0)
"""The waist untwisted: the pelvis and legs follow the torso onto the front."""

PRONE_HANDS = _symmetric((0.0, -0.05, 0.0, 0.1, 0.3, 0.0), 0.0,
                         (0.46, 0.36, 0.0, -0.59, 0, 0, 0))
"""Prone with the hands by the chest (the start of the tuck)."""

KNEE_CHEST = _symmetric((-0.39, -1.92, 0.28, 1.67, -0.1, -0.24), 0.0,
                        (-0.34, 0.35, 0.34, -0.74, 0.0, -0.42, 0.0))
"""Knee-chest: knees under the hips, toes tucked, chest and head down, hands by the
head: the hand-over state the shipped policy rises from."""

HANDS_KNEES = _symmetric((-0.28, -1.48, 0.19, 1.97, 0.15, -0.24), 0.0,
                         (-1.30, 0.23, 0.01, 1.37, 0.0, -0.04, 0.01))
"""On hands and knees: thighs vertical, arms straight under the shoulders."""

KNEEL_UPRIGHT = _symmetric((0.04, -0.18, -0.02, 1.98, 0.12, 0.01), 0.0,
                           (0.17, 0.20, 0.0, 0.59, 0, 0, 0))
"""Kneeling upright on both knees, torso vertical, knees within the 0.9× range."""

SIDE_SIT = np.array([-0.39, -2.83, 0.69, 1.60, 0.0, -0.13, -0.04, -1.71, -0.10, 1.63, 0.01,
                     0.24, 1.20, -1.08, -0.01, 0.0, 1.02, 0.0, -0.05, 0.01, -0.99, -0.14,
                     0.04, 1.12, 0.0, -0.04, 0.02])
"""Side-sit: the pelvis rolled onto its left hip, the waist twisted 1.2 rad towards the
floor, both hands down in front (asymmetric)."""

KEYFRAMES: dict[str, np.ndarray] = {
    "supine_rest": SUPINE_REST, "tuck": TUCK, "roll_twist": ROLL_TWIST,
    "roll_unwind": ROLL_UNWIND, "prone_hands": PRONE_HANDS, "knee_chest": KNEE_CHEST,
    "hands_knees": HANDS_KNEES, "kneel_upright": KNEEL_UPRIGHT, "side_sit": SIDE_SIT,
}
"""Every keyframe by name."""

for _name, _q in KEYFRAMES.items():
    assert _q.shape == (constants.NUM_JOINTS,), _name
    _q.setflags(write=False)
