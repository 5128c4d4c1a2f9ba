"""When a MuJoCo simulation has diverged: from then on its state means nothing.

MuJoCo answers a non-finite or huge position, velocity or acceleration with a warning
(``mjWARN_BADQPOS``, ``mjWARN_BADQVEL``, ``mjWARN_BADQACC``) and resets the data to the
model's reference configuration, pushes cleared: the robot then stands at ``qpos0`` and,
read as a state, looks recovered. A non-finite control (``mjWARN_BADCTRL``) is replaced by
zeros. Every runner that steps MuJoCo asks :func:`divergence` (or
:func:`divergence_after_step`) after its steps and ends the trial as diverged, never as a
success.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

DIVERGENCE_WARNINGS: dict[mujoco.mjtWarning, str] = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "non-finite or huge position",
    mujoco.mjtWarning.mjWARN_BADQVEL: "non-finite or huge velocity",
    mujoco.mjtWarning.mjWARN_BADQACC: "non-finite or huge acceleration",
    mujoco.mjtWarning.mjWARN_BADCTRL: "non-finite control",
}
"""MuJoCo's warnings that mark a diverged simulation, with what each says."""

MAX_SPEED = 1e3
"""A generalised speed |q̇_i| above which the state counts as diverged [m/s, rad/s]
(the training environment's threshold)."""

_WARNINGS = tuple((int(w), w.name, what) for w, what in DIVERGENCE_WARNINGS.items())
"""(index into ``MjData.warning``, name, what it says) of each divergence warning."""


class SimulationDiverged(RuntimeError):
    """A simulation diverged; the message says why and when."""


def divergence(data: mujoco.MjData) -> str | None:
    """Why the simulation of ``data`` has diverged, or None while it has not.

    Diverged: a warning of :data:`DIVERGENCE_WARNINGS` was raised since ``data`` was made
    (MuJoCo's own reset keeps the count), or qpos / qvel hold a non-finite value, or
    |q̇_i| > :data:`MAX_SPEED`.

    Returns:
        e.g. ``"MuJoCo: non-finite or huge acceleration (mjWARN_BADQACC) at DOF 1"``.
    """
    counts = data.warning.number.tolist()  # all warnings' counts in one call
    for index, name, what in _WARNINGS:
        if counts[index] > 0:
            where = "ACTUATOR" if index == mujoco.mjtWarning.mjWARN_BADCTRL else "DOF"
            return f"MuJoCo: {what} ({name}) at {where} {data.warning[index].lastinfo}"
    qpos, qvel = data.qpos, data.qvel
    # fast path: ‖q̇‖² ≤ MAX_SPEED² bounds every |q̇_i|; NaN fails the comparisons
    if qvel @ qvel <= MAX_SPEED**2 and math.isfinite(qpos @ qpos):
        return None
    if not (np.isfinite(qpos).all() and np.isfinite(qvel).all()):
        return "non-finite state"
    speed = float(np.abs(qvel).max(initial=0.0))
    return f"speed {speed:.3g} above {MAX_SPEED:g}" if speed > MAX_SPEED else None


def divergence_after_step(model: mujoco.MjModel, data: mujoco.MjData, time_before: float,
                          check_all: bool) -> str | None:
    """:func:`divergence` after one ``mj_step`` from ``time_before`` [s], at less cost per
    step: MuJoCo's reset of an unstable simulation sends its clock back, which is always
    checked; the other signs (a non-finite control, a runaway speed) only where
    ``check_all`` (a runner sets it before each sample it records).

    Returns:
        Why and when (``... at t = 1.005 s``, the end of the step), or None.
    """
    if not check_all and data.time >= time_before:
        return None
    why = divergence(data)
    return None if why is None else f"{why} at t = {time_before + model.opt.timestep:.3f} s"


def clock_broken(before: np.ndarray, after: np.ndarray, elapsed: float,
                 timestep: float) -> np.ndarray:
    """The simulations of a batch whose clock did not advance by the ``elapsed`` time of a
    step call: those MuJoCo reset as unstable in it (time restarts at 0) or had stopped
    stepping since. Warnings counters of a ``mujoco.batch.Batch`` are not read: they are
    copied out one call late.

    Args:
        before, after: ``time`` of every simulation before and after the call, (N,) [s].
        elapsed: the time the call steps, ``nstep`` × ``timestep`` [s].
        timestep: the physics step [s].

    Returns:
        (N,) bool.
    """
    return np.abs(after - before - elapsed) > 0.5 * timestep
