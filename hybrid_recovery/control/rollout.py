"""Closed-loop episodes of a torque controller: torso pushes, sensor noise, success check.

A controller is any object with ``reset(model, data)`` and ``__call__(model, data) ->
τ (27,)`` (the :class:`BalanceController`, the :class:`HybridSupervisor`). The model is a
torque model (:func:`hybrid_recovery.control.torque_model.load_torque_model`).

Success ("standing"), as in the benchmark: CoM height > 0.85 m, torso tilt < 72° from
vertical and no robot geom other than the soles touching the ground.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np

from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import default_qpos
from hybrid_recovery.sim.divergence import divergence

STANDING_MAX_TILT_DEG = 72.0
"""Success: torso tilt from vertical below this [deg]."""


class TorqueController(Protocol):
    """``reset(model, data)``, then ``controller(model, data) -> τ (27,)`` every step."""

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData) -> None: ...

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray: ...


@dataclass
class Push:
    """A constant force at the CoM of a body (``xfrc_applied``), world frame.

    Attributes:
        force: F, shape (3,) [N].
        start: Onset time [s].
        duration: [s].
        body: Body name; the torso by default.
    """

    force: np.ndarray
    start: float = 0.5
    duration: float = 0.1
    body: str = constants.TORSO_BODY


@dataclass
class SensorNoise:
    """Zero-mean Gaussian noise on the state the controller sees (std devs).

    Attributes:
        joint_pos: q [rad]. joint_vel: q̇ [rad/s]. base_rot: base orientation [rad].
        base_angvel: ω [rad/s]. base_linvel: v [m/s]. base_pos: p [m].
    """

    joint_pos: float = 0.0
    joint_vel: float = 0.0
    base_rot: float = 0.0
    base_angvel: float = 0.0
    base_linvel: float = 0.0
    base_pos: float = 0.0


@dataclass
class EpisodeResult:
    """Outcome of :func:`run_episode`.

    Attributes:
        standing: Success at the end (see the module docstring).
        com_height: Final CoM height [m].
        tilt_deg: Final torso tilt [deg].
        non_foot_contact: A non-sole geom touches the ground at the end.
        com: CoM trajectory, shape (T + 1, 3) [m] (first row before the first step).
        diagnostics: The controller's per-tick ``diagnostics`` (empty if it has none).
        max_torque_ratio: max_t,i |τ_i| / τ_max,i.
        finite: All torques were finite.
        divergence: Why and when the simulation diverged (the episode stopped there and
            is not standing), None if it did not.
    """

    standing: bool
    com_height: float
    tilt_deg: float
    non_foot_contact: bool
    com: np.ndarray
    diagnostics: list = field(default_factory=list)
    max_torque_ratio: float = 0.0
    finite: bool = True
    divergence: str | None = None


def standing_data(model: mujoco.MjModel) -> mujoco.MjData:
    """Data at the default standing pose q*, at rest, forward-evaluated."""
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    mujoco.mj_forward(model, data)
    return data


def standing_state(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[bool, float, float, bool]:
    """(standing, CoM height [m], torso tilt [deg], non-foot contact) of forward-evaluated data."""
    height = float(data.subtree_com[model.body(constants.PELVIS_BODY).id, 2])
    zz = data.body(constants.TORSO_BODY).xmat[8]
    tilt = float(np.degrees(np.arccos(np.clip(zz, -1.0, 1.0))))
    feet = {model.body(b).id for b in constants.FOOT_BODIES}
    other = any(
        model.geom_bodyid[g] not in feet and model.geom_bodyid[g] != 0
        for c in data.contact[: data.ncon] for g in c.geom
    )
    ok = height > constants.UPRIGHT_COM_HEIGHT and tilt < STANDING_MAX_TILT_DEG and not other
    return ok, height, tilt, other


def measured(data: mujoco.MjData, noise: SensorNoise, rng: np.random.Generator) -> mujoco.MjData:
    """A copy of ``data`` whose qpos/qvel carry ``noise`` (contacts unchanged)."""
    out = copy.copy(data)
    out.qpos[0:3] += rng.normal(0.0, noise.base_pos, 3)
    quat = out.qpos[3:7].copy()
    mujoco.mju_quatIntegrate(quat, rng.normal(0.0, noise.base_rot, 3), 1.0)
    out.qpos[3:7] = quat
    out.qpos[7:] += rng.normal(0.0, noise.joint_pos, out.qpos.size - 7)
    out.qvel[0:3] += rng.normal(0.0, noise.base_linvel, 3)
    out.qvel[3:6] += rng.normal(0.0, noise.base_angvel, 3)
    out.qvel[6:] += rng.normal(0.0, noise.joint_vel, out.qvel.size - 6)
    return out


def run_episode(
    model: mujoco.MjModel,
    controller: TorqueController,
    duration: float,
    push: Push | None = None,
    noise: SensorNoise | None = None,
    data: mujoco.MjData | None = None,
    seed: int = 0,
    keep_diagnostics: bool = False,
    stop_below: float | None = None,
) -> EpisodeResult:
    """Resets the controller on ``data`` (standing at q* by default) and runs it.

    Args:
        model: Torque model (ctrl = τ).
        controller: The controller under test.
        duration: Simulated time [s].
        push: Optional torso push.
        noise: Optional sensor noise on what the controller sees.
        data: Initial state; :func:`standing_data` when None.
        seed: Noise seed.
        keep_diagnostics: Keep the controller's ``diagnostics`` of every tick.
        stop_below: End the episode early (a failure) once the CoM is below this height
            [m]; for controllers that cannot stand up again. None runs to the end.

    Returns:
        The :class:`EpisodeResult`; an episode whose simulation diverged
        (:func:`~hybrid_recovery.sim.divergence.divergence`) stops there, not standing.
    """
    data = standing_data(model) if data is None else data
    rng = np.random.default_rng(seed)
    controller.reset(model, data)
    body = model.body(push.body).id if push is not None else -1
    steps = int(round(duration / model.opt.timestep))
    com = np.empty((steps + 1, 3))
    com[0] = data.subtree_com[1]
    diags, ratio, finite = [], 0.0, True
    diverged: str | None = None
    for k in range(steps):
        if push is not None:
            on = push.start <= data.time < push.start + push.duration
            data.xfrc_applied[body, :3] = push.force if on else 0.0
        seen = data if noise is None else measured(data, noise, rng)
        torque = controller(model, seen)
        finite &= bool(np.all(np.isfinite(torque)))
        ratio = max(ratio, float(np.max(np.abs(torque) / constants.EFFORT_LIMITS)))
        data.ctrl[:] = torque
        diag = getattr(controller, "diagnostics", None)
        if keep_diagnostics and diag is not None:
            diags.append(diag)
        t = data.time
        mujoco.mj_step(model, data)
        if (diverged := divergence(data)) is not None:
            com = com[: k + 1]
            diverged += f" at t = {t + model.opt.timestep:.3f} s"
            break
        com[k + 1] = data.subtree_com[1]
        if stop_below is not None and com[k + 1, 2] < stop_below:
            com = com[: k + 2]
            break
    mujoco.mj_forward(model, data)
    ok, height, tilt, other = standing_state(model, data)
    return EpisodeResult(ok and diverged is None, height, tilt, other, com, diags, ratio,
                         finite, diverged)
