"""One evaluation trial in plain MuJoCo: start pose, torso push, controller, measurements."""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.dynamics.capturability import capture_point
from hybrid_recovery.envs.config import DomainRandConfig
from hybrid_recovery.envs.terminations import SUCCESS_TIME, upright
from hybrid_recovery.evaluation.contact import apply_contact_preset
from hybrid_recovery.evaluation.motor_use import MotorUse, prepare_model
from hybrid_recovery.evaluation.off_nominal import (
    ActuationDelay,
    apply_off_nominal,
    delay_steps,
)
from hybrid_recovery.evaluation.scenario import Scenario, check_pose
from hybrid_recovery.evaluation.strategy import CONTACT_BODIES, label_strategy
from hybrid_recovery.evaluation.success import recovery_time, stuck_low
from hybrid_recovery.evaluation.terrain_results import declined_reason, declined_row
from hybrid_recovery.observation import projected_gravity
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import H1_2_MJCF, load_spec
from hybrid_recovery.sim.divergence import divergence, divergence_after_step
from hybrid_recovery.sim.initial_states import mirror_qpos, perturb_start, settle_pool
from hybrid_recovery.sim.terrain import ground_height, parse_terrain
from hybrid_recovery.sim.terrain_model import add_terrain, seat_on_terrain

RECORD_DT = 0.02
"""Sampling period of the recorded trace [s] (50 Hz, the control rate)."""
POOL_SIZE = 8
"""Settled start states per pose and model."""


@functools.lru_cache(maxsize=16)
def eval_model(model_path: str | None, timestep: float, torque_control: bool,
               contact: str, rotor_inertia: bool = False, terrain: str = "flat",
               actuator: str = "ideal", motor_strength: float = 1.0,
               payload: float = 0.0) -> mujoco.MjModel:
    """The evaluation model (cached per process): robot, floor, actuators, contact preset;
    loaded as sim-to-sim loads it (:func:`hybrid_recovery.robot.mjcf.load_spec`), on
    ``terrain`` (:mod:`hybrid_recovery.sim.terrain_model`), its actuators ready for the
    motor model ``actuator`` (:func:`~hybrid_recovery.evaluation.motor_use.prepare_model`),
    the robot off-nominal with ``motor_strength`` and ``payload`` [kg]
    (:func:`~hybrid_recovery.evaluation.off_nominal.apply_off_nominal`)."""
    if torque_control:
        from hybrid_recovery.control.torque_model import torque_spec

        spec = torque_spec(model_path, timestep=timestep, rotor_inertia=rotor_inertia)
    else:
        spec = load_spec(model_path, timestep=timestep, rotor_inertia=rotor_inertia)
    add_terrain(spec, parse_terrain(terrain))
    try:
        model = spec.compile()
    except ValueError as err:
        raise ValueError(f"cannot compile H1-2 MJCF {model_path or H1_2_MJCF}: {err}") from None
    apply_contact_preset(model, contact)
    prepare_model(model, actuator)
    apply_off_nominal(model, motor_strength, payload)
    return model


def physics_step(controller, model_path: str | None) -> float:
    """The controller's physics step; at most 1 ms on another model (the reference mesh
    model has no joint armature and needs the finer step to stay stable)."""
    return controller.physics_dt if model_path is None else min(controller.physics_dt, 0.001)


@functools.lru_cache(maxsize=4)
def _pool(model_path: str | None, contact: str, timestep: float, rotor_inertia: bool) -> dict:
    model = eval_model(model_path, timestep, False, contact, rotor_inertia)
    return settle_pool(model, POOL_SIZE, np.random.default_rng(12345), nthread=1)


def start_state(scenario: Scenario, model_path: str | None, contact: str,
                timestep: float = 0.005, rotor_inertia: bool = False) -> np.ndarray:
    """The trial's initial qpos: a settled state of the pose with the paper's
    initialisation noise scaled by ``scenario.noise``.

    A push with a rightward component (sin(direction) < 0) starts from the mirror image
    (:func:`~hybrid_recovery.sim.initial_states.mirror_qpos`) of the state its leftward
    twin starts from, so that left and right cells differ only in the side pushed.

    Raises:
        ValueError: an unknown pose.
    """
    check_pose(scenario.pose)
    model = eval_model(model_path, timestep, False, contact, rotor_inertia)
    pool = _pool(model_path, contact, timestep, rotor_inertia)[scenario.pose][0]
    rng = np.random.default_rng(scenario.seed)
    dr, k = DomainRandConfig(), scenario.noise
    qadr = model.jnt_qposadr[1:1 + constants.NUM_JOINTS]
    start = pool[rng.integers(len(pool))][None]
    qpos = perturb_start(start, rng, k * dr.init_base_pos, k * dr.init_base_rot,
                         k * dr.init_joint_pos, qadr,
                         model.jnt_range[1:1 + constants.NUM_JOINTS])[0]
    if scenario.force > 0 and np.sin(scenario.direction) < -1e-9:
        qpos = mirror_qpos(qpos, qadr)
    return qpos


def run_trial(controller, scenario: Scenario, model_path: str | Path | None = None,
              contact: str = "default", record: bool = False,
              on_sample: Callable[[mujoco.MjModel, mujoco.MjData, np.ndarray], None]
              | None = None, rotor_inertia: bool = False,
              start_qpos: np.ndarray | None = None, stop_on_success: bool = False,
              actuator: str = "ideal") -> dict:
    """Runs one trial and measures it.

    ``on_sample(model, data, push_force)`` is called at every recorded sample (50 Hz),
    e.g. to render frames. ``rotor_inertia`` gives a model file without armature the
    project's rotor inertia; ``start_qpos`` (nq,) replaces the scenario's start state.
    With ``stop_on_success`` the trial ends as soon as the success criterion is met (the
    standing condition held for 1 s after the push), which leaves ``success`` and
    ``recovery_time`` unchanged and shortens the trial.

    The simulation is checked after every step and before every sample
    (:func:`~hybrid_recovery.sim.divergence.divergence_after_step`): a trial whose
    simulation diverged (a MuJoCo instability warning and its reset, a non-finite start or
    state, a runaway speed) ends there as ``diverged``, never as a success; the
    measurements up to then are kept.

    On terrain (``scenario.terrain``) the start is seated on the ground
    (:func:`~hybrid_recovery.sim.terrain_model.seat_on_terrain`) and every height is the
    CoM's above the ground under it; a controller whose ground model is flat declines
    (:func:`~hybrid_recovery.evaluation.terrain_results.declined_reason`). ``actuator``
    is the motor model (``ideal`` or ``dc``,
    :class:`~hybrid_recovery.evaluation.motor_use.MotorUse`). An off-nominal robot
    (``scenario.motor_strength``, ``payload``, ``delay``) is simulated while the
    controller computes on the nominal model, its output ``delay_steps`` physics steps
    late (:mod:`~hybrid_recovery.evaluation.off_nominal`).

    Returns:
        A flat dict: the scenario, ``success`` (the paper's criterion, after the push for a
        pushed trial), ``recovery_time`` [s] from the start, or from the end of the push
        (None on failure), ``standing_at_end``,
        ``fell`` (CoM below 0.5 m at some point), ``stuck_low`` (the training env's
        stuck-low termination would have ended the trial), ``peak_torque`` [N·m], ``time_low`` (time
        with the CoM below 0.85 m) [s], ``strategy``, ``not_applicable`` (the controller
        declined the situation), ``diverged`` and ``divergence`` (why and when, None
        unless diverged; a diverged trial has ``success``, ``standing_at_end`` and
        ``stuck_low`` false, no ``recovery_time`` and the strategy ``diverged``), and
        with ``record`` a ``trace`` of arrays at 50 Hz; the motors' figures
        (:meth:`~hybrid_recovery.evaluation.motor_use.MotorUse.summary`); ``declined``
        (why) for a trial the controller declined; ``delay_steps``, the added delay in
        physics steps.
    """
    path = None if model_path is None else str(model_path)
    ground = parse_terrain(scenario.terrain)
    if (reason := declined_reason(controller.name, ground)) is not None:
        return declined_row(scenario, controller.name, path, contact, rotor_inertia, reason)
    timestep = physics_step(controller, path)
    nominal = eval_model(path, timestep, controller.output == "torque", contact,
                         rotor_inertia, scenario.terrain, actuator)
    model = eval_model(path, timestep, controller.output == "torque", contact,
                       rotor_inertia, scenario.terrain, actuator, scenario.motor_strength,
                       scenario.payload)
    data = mujoco.MjData(model)
    data.qpos[:] = (start_state(scenario, path, contact, timestep, rotor_inertia)
                    if start_qpos is None else start_qpos)
    seat_on_terrain(model, data, ground)
    mujoco.mj_forward(model, data)
    diverged = divergence(data)  # a non-finite start: no step, no controller
    if diverged is not None:
        diverged += " at the start"
    else:
        data.ctrl[:] = 0.0 if controller.output == "torque" else data.qpos[
            model.jnt_qposadr[1:1 + constants.NUM_JOINTS]]
        controller.reset(nominal, data)
    late = ActuationDelay(delay_steps(scenario.delay, timestep), data.ctrl)
    torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, constants.TORSO_BODY)
    groups = _contact_group_of_body(model)
    dt = model.opt.timestep
    every = max(1, int(round(RECORD_DT / dt)))
    steps = 0 if diverged else max(1, int(round(scenario.duration / dt)))
    push_steps = range(int(round(scenario.push_time / dt)),
                       int(round((scenario.push_time + scenario.push_duration) / dt)))
    push = np.zeros(3)
    trace: dict[str, list] = {k: [] for k in ("t", "com", "com_vel", "ang_mom", "cp",
                                              "gravity_b", "contacts", "feet_xy", "hip")}
    peak_torque = 0.0
    t_start = scenario.push_time + scenario.push_duration if scenario.force > 0 else 0.0
    need = int(np.ceil(SUCCESS_TIME / (every * dt) - 1e-9))
    streak = 0
    motors = MotorUse(model, actuator, scenario.motor_strength)
    hip_adr = model.jnt_qposadr[[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)
                                 for n in ("left_hip_pitch_joint", "right_hip_pitch_joint")]]
    for k in range(steps):
        if k == push_steps.start and scenario.force > 0:
            w, x, y, z = data.xquat[torso]
            yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
            angle = yaw + scenario.direction
            push = scenario.force * np.array([np.cos(angle), np.sin(angle), 0.0])
        if k in push_steps and scenario.force > 0:
            point = data.subtree_com[1] + np.array([0.0, 0.0, scenario.height])
            data.xfrc_applied[torso, :3] = push
            data.xfrc_applied[torso, 3:] = np.cross(point - data.xipos[torso], push)
        elif k == push_steps.stop:
            data.xfrc_applied[torso] = 0.0
        data.ctrl[:] = late(controller(nominal, data))
        if k % every == 0:
            _record(model, data, trace, groups, hip_adr, torso)
            if on_sample is not None:
                on_sample(model, data, data.xfrc_applied[torso, :3].copy())
            if stop_on_success:
                com_now = trace["com"][-1]
                now = upright(np.array([com_now[2] - ground_height(ground, com_now[:2])]),
                              np.array([trace["com_vel"][-1][2]]),
                              trace["gravity_b"][-1][None])[0] and data.time >= t_start - 1e-9
                streak = streak + 1 if now else 0
                if streak >= need:
                    break
        before = data.time
        motors.before_step(model, data)
        mujoco.mj_step(model, data)
        diverged = divergence_after_step(model, data, before, (k + 1) % every == 0)
        if diverged is not None:
            break
        motors.after_step(data)
        peak_torque = max(peak_torque, float(np.abs(data.actuator_force).max()))
    if diverged is None and steps:  # the steps after the last sample
        diverged = divergence_after_step(model, data, data.time - dt, True)
    if not trace["t"]:  # a diverged start: its one sample
        _record(model, data, trace, groups, hip_adr, torso)
    arrays = {k: np.asarray(v) for k, v in trace.items()}
    com = arrays["com"]
    height = com[:, 2] - ground_height(ground, com[:, :2])
    t0 = scenario.push_time + scenario.push_duration if scenario.force > 0 else 0.0
    t_rec = None if diverged else recovery_time(arrays["t"], height, arrays["com_vel"][:, 2],
                                                arrays["gravity_b"], start=t0)
    info = controller.info() if hasattr(controller, "info") and steps else {}
    result = {
        **scenario.to_dict(), "key": scenario.key, "controller": controller.name,
        "model": path or "own", "contact": contact, "rotor_inertia": rotor_inertia,
        "success": t_rec is not None, "recovery_time": t_rec,
        "standing_at_end": not diverged and bool(height[-1] > constants.UPRIGHT_COM_HEIGHT),
        "fell": bool((height < 0.5).any()),
        "stuck_low": not diverged and stuck_low(height, RECORD_DT),
        "peak_torque": peak_torque,
        "time_low": float((height < constants.UPRIGHT_COM_HEIGHT).sum() * RECORD_DT),
        "strategy": "diverged" if diverged else label_strategy(
            arrays, scenario.push_time if scenario.force > 0 else None),
        "not_applicable": bool(info.pop("not_applicable", False)),
        "diverged": diverged is not None, "divergence": diverged,
        "delay_steps": late.steps, "controller_info": info, **motors.summary(),
    }
    if record:
        result["trace"] = arrays
    return result


def _contact_group_of_body(model: mujoco.MjModel) -> np.ndarray:
    """Contact group index (into CONTACT_BODIES) of each body, −1 for none."""
    group = -np.ones(model.nbody, dtype=int)
    for g, (_, bodies) in enumerate(CONTACT_BODIES.items()):
        for name in bodies:
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
            if body >= 0:
                group[body] = g
    return group


def _record(model, data, trace, groups, hip_adr, torso) -> None:
    mujoco.mj_subtreeVel(model, data)
    com, vel = data.subtree_com[1].copy(), data.subtree_linvel[1].copy()
    trace["t"].append(data.time)
    trace["com"].append(com)
    trace["com_vel"].append(vel)
    trace["ang_mom"].append(data.subtree_angmom[1].copy())
    trace["cp"].append(capture_point(com[:2], vel[:2], max(com[2], 1e-3)))
    trace["gravity_b"].append(projected_gravity(data.xquat[torso]))
    touching = np.zeros(len(CONTACT_BODIES), dtype=bool)
    feet_xy = np.full((2, 4, 2), np.nan)
    nfoot = [0, 0]
    for c in data.contact[:data.ncon]:
        for geom in (c.geom[0], c.geom[1]):
            g = groups[model.geom_bodyid[geom]]
            if g >= 0:
                touching[g] = True
                if g < 2 and nfoot[g] < 4:
                    feet_xy[g, nfoot[g]] = c.pos[:2]
                    nfoot[g] += 1
    trace["contacts"].append(touching)
    trace["feet_xy"].append(feet_xy)
    trace["hip"].append(data.qpos[hip_adr].copy())
