"""The motors in an evaluation trial: the torque–speed curve applied, the speeds and
saturation measured.

:class:`MotorUse` runs beside :func:`~hybrid_recovery.evaluation.trial.run_trial`: before
each physics step it writes the available torque interval of the motor model
(:mod:`hybrid_recovery.robot.actuator`) into the actuators' force ranges (``dc``; the
model's own ±τ_lim for ``ideal``); after it, it counts the step's joint speeds against
the manufacturer's limits and the joints held at their torque bound.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.robot import constants
from hybrid_recovery.robot.actuator import torque_limits

AT_LIMIT = 1.0 - 1e-6
"""A joint's torque counts as at its bound from this fraction of the bound on."""


def prepare_model(model: mujoco.MjModel, actuator: str) -> None:
    """Makes every actuator of ``model`` (one per joint, motor order) clamp its force to
    ``force_range`` (±τ_lim until :meth:`MotorUse.before_step` writes the curve's);
    nothing for ``ideal``."""
    if actuator == "dc":
        model.actuator_forcelimited[:] = 1
        model.actuator_forcerange[:] = np.stack(
            [-constants.EFFORT_LIMITS, constants.EFFORT_LIMITS], 1)


class MotorUse:
    """Applies the motor model and measures one trial's joint speeds and saturation.

    Args:
        model: the trial's model: actuator i drives ``constants.JOINT_NAMES[i]``
            (position servos or torque motors), prepared by :func:`prepare_model`.
        actuator: ``ideal`` or ``dc``.
        strength: the motors' rated torque as a fraction of τ_lim (weak motors: < 1).
    """

    def __init__(self, model: mujoco.MjModel, actuator: str, strength: float = 1.0) -> None:
        self.actuator = actuator
        self.effort = strength * constants.EFFORT_LIMITS
        self.dadr = model.jnt_dofadr[model.actuator_trnid[:, 0]]
        self.low, self.high = torque_limits("ideal", np.zeros(model.nu), self.effort)
        self.steps = 0
        self.over_steps = 0
        self.limit_steps = 0
        self.worst_ratio = 0.0
        self.dt = model.opt.timestep

    def before_step(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Writes the torque interval available at the present joint speeds (``dc``)."""
        if self.actuator == "ideal":
            return
        self.low, self.high = torque_limits(self.actuator, data.qvel[self.dadr], self.effort)
        model.actuator_forcerange[:, 0] = self.low
        model.actuator_forcerange[:, 1] = self.high

    def after_step(self, data: mujoco.MjData) -> None:
        """Counts the step: joint speeds |ω| / ω_max after it, torques at their bound in it."""
        ratio = np.abs(data.qvel[self.dadr]) / constants.VELOCITY_LIMITS
        force = data.actuator_force
        self.steps += 1
        self.over_steps += bool((ratio > 1.0).any())
        self.worst_ratio = max(self.worst_ratio, float(ratio.max()))
        at = ((force >= AT_LIMIT * self.high) & (self.high > 0)) | \
             ((force <= AT_LIMIT * self.low) & (self.low < 0))
        self.limit_steps += bool(at.any())

    def summary(self) -> dict:
        """The trial's figures: ``actuator``; ``over_velocity_share``, the share of physics
        steps with some joint over its velocity limit; ``worst_velocity_ratio``, the largest
        |ω| / ω_max of any joint; ``time_at_effort_limit`` [s], the time with some joint's
        torque at the bound of its available interval (±τ_lim, or the curve's)."""
        return {"actuator": self.actuator,
                "over_velocity_share": self.over_steps / max(self.steps, 1),
                "worst_velocity_ratio": self.worst_ratio,
                "time_at_effort_limit": self.limit_steps * self.dt}


def motor_table(results: dict[str, list[dict]]) -> str:
    """Markdown table, one row per controller: the motor model and the trials' joint
    speeds and saturation (median and worst over the trials); empty for results
    without them."""
    lines = ["| controller | actuator | trials | steps over ω_max (median, max) | "
             "worst abs(ω)/ω_max (median, max) | time at effort limit [s] (median) |",
             "|---|---|---|---|---|---|"]
    for label, rows in results.items():
        rows = [r for r in rows if "over_velocity_share" in r]
        if not rows:
            continue
        share = [r["over_velocity_share"] for r in rows]
        worst = [r["worst_velocity_ratio"] for r in rows]
        at = [r["time_at_effort_limit"] for r in rows]
        lines.append(f"| {label} | {rows[0]['actuator']} | {len(rows)} | "
                     f"{np.median(share):.1%}, {max(share):.1%} | "
                     f"{np.median(worst):.2f}, {max(worst):.2f} | {np.median(at):.2f} |")
    return "\n".join(lines) if len(lines) > 2 else ""
