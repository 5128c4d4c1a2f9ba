"""Automatic labels of the balance strategy used in a trial, from its trace.

Rules, applied to the part of the trial after the push starts, most drastic first:

* ``multi_contact``: a hand, elbow, knee, pelvis or torso touched the ground;
* ``stepping``: a foot lost ground contact for ≥ 0.06 s (lift-off) and touched down again;
* ``hip``: the centroidal angular momentum ‖L‖ exceeded 3 kg·m²/s, or a hip pitch joint
  moved more than 0.15 rad from its value at the push (upper body used as a flywheel);
* ``ankle``: otherwise (the CoP moved inside the feet only);
* ``none``: no push in the trial.
"""

from __future__ import annotations

import numpy as np

CONTACT_BODIES: dict[str, tuple[str, ...]] = {
    "left_foot": ("left_ankle_roll_link", "left_ankle_pitch_link"),
    "right_foot": ("right_ankle_roll_link", "right_ankle_pitch_link"),
    "hands": ("left_wrist_yaw_link", "right_wrist_yaw_link", "left_wrist_pitch_link",
              "right_wrist_pitch_link", "left_wrist_roll_link", "right_wrist_roll_link"),
    "elbows": ("left_elbow_link", "right_elbow_link"),
    "knees": ("left_knee_link", "right_knee_link"),
    "pelvis": ("pelvis", "left_hip_roll_link", "right_hip_roll_link"),
    "torso": ("torso_link",),
}
"""Contact groups of the trace's ``contacts`` columns, in this order."""

ANGULAR_MOMENTUM_HIP = 3.0
"""‖L‖ above which the hip strategy is declared [kg·m²/s]."""
HIP_EXCURSION = 0.15
"""Hip pitch excursion above which the hip strategy is declared [rad]."""
LIFT_OFF_TIME = 0.06
"""Minimum foot flight time of a step [s]."""


def label_strategy(trace: dict[str, np.ndarray], push_time: float | None) -> str:
    """The strategy label of one trial (see the module docstring)."""
    if push_time is None:
        return "none"
    t = trace["t"]
    after = t >= push_time
    if not after.any():
        return "none"
    contacts = trace["contacts"][after]
    if contacts[:, 2:].any():
        return "multi_contact"
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.02
    need = max(1, int(round(LIFT_OFF_TIME / dt)))
    for foot in (0, 1):
        touching = contacts[:, foot]
        run, lifted = 0, False
        for flag in touching:
            run = 0 if flag else run + 1
            if run >= need:
                lifted = True
            if lifted and flag:
                return "stepping"
    momentum = np.linalg.norm(trace["ang_mom"][after], axis=1)
    hip = trace["hip"][after]
    if momentum.max() > ANGULAR_MOMENTUM_HIP or np.abs(hip - hip[0]).max() > HIP_EXCURSION:
        return "hip"
    return "ankle"
