"""Sim-to-sim: a controller in MuJoCo at 1 kHz physics as on the robot (a policy at 50 Hz).

The same pieces as on the robot, without DDS: the runner of ``--controller``
(:func:`~.controller_runner.make_runner`: the policy on the training observation builder,
or any registered controller on the state estimated from the robot's sensors),
:class:`~.state_machine.SafetyStateMachine` (faults → damping) and the motor drivers of
:class:`~.sim_robot.SimRobot` (PD from the command's gains, feed-forward torque). Any H1-2
MJCF loads: the project's own (default) or the manufacturer's mesh model, through the
same loader as the evaluation (:func:`hybrid_recovery.robot.mjcf.load_spec`). Start poses
are settled as in training (:func:`hybrid_recovery.sim.initial_states.settle_pool`); a
torso push and an actuation delay can be added. Writes ``trace.csv``, ``trace.png``,
``summary.json`` and, with a renderer, ``video.mp4``.

The video is drawn with OpenGL where a context can be made, else in software
(:class:`hybrid_recovery.sim.render.BalanceRenderer`); ``summary.json`` names which.
"""

from __future__ import annotations

import json
import math
from collections import deque
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from hybrid_recovery.deploy.balance_trace import BalanceTrace
from hybrid_recovery.deploy.controller_runner import make_runner
from hybrid_recovery.deploy.robot_io import JointCommand
from hybrid_recovery.deploy.sim_robot import SimRobot, SimRobotConfig
from hybrid_recovery.deploy.state_machine import Phase, SafetyConfig, SafetyStateMachine
from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.files import atomic_path, atomic_write_text, refuse_existing
from hybrid_recovery.observation import projected_gravity
from hybrid_recovery.robot.constants import UPRIGHT_COM_HEIGHT
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.sim.divergence import (
    SimulationDiverged,
    divergence,
    divergence_after_step,
)
from hybrid_recovery.sim.initial_states import POSES, settle_pool
from hybrid_recovery.sim.scene import build_scene


@dataclass
class Sim2SimConfig:
    """A sim-to-sim run."""

    model_path: str | None = None
    """H1-2 MJCF; None for the project's own."""
    rotor_inertia: bool = False
    """Give the joints the project's rotor inertia (for a file without armature)."""
    start_qpos: np.ndarray | None = None
    """Start configuration (nq,), at rest, instead of the settled ``pose``."""
    pose: str = "standing"
    """Start pose, one of ``initial_states.POSES``, settled for its settle time."""
    seconds: float = 10.0
    push_force: float = 0.0
    """Horizontal force on the torso [N]; 0 for none."""
    push_direction_deg: float = 0.0
    """Direction of the push in the world x–y plane [deg] (0 = +x, the robot's front)."""
    push_time: float = 2.0
    """[s] after the start."""
    push_duration: float = 0.2
    """[s]."""
    delay_s: float = 0.0
    """Actuation delay between a command and its use by the motors [s] (training: 10–40 ms)."""
    startup: bool = False
    """Run the hardware start-up (zero torque → interpolate → hold) before the policy;
    by default the policy acts from the start pose (the safety monitors still run)."""
    video: bool = True
    fps: int = 25
    width: int = 480
    height: int = 360
    seed: int = 0


def start_state(model_path: str | None, pose: str, physics_dt: float,
                seed: int = 0, rotor_inertia: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """A settled (qpos, qvel) of ``pose`` on the given model (no joint noise)."""
    if pose not in POSES:
        raise ValueError(f"pose must be one of {POSES}, got {pose!r}")
    model, _ = build_scene(model_path, physics_dt, rotor_inertia=rotor_inertia)
    pool = settle_pool(model, per_pose=1, rng=np.random.default_rng(seed), joint_noise=0.0,
                       nthread=1)
    qpos, qvel = pool[pose]
    return qpos[0], qvel[0]


OUTPUTS = ("trace.csv", "trace.png", "summary.json", "video.mp4")
"""The files a run writes into its output directory (each atomically)."""


def check_output(out_dir: str | Path, force: bool) -> None:
    """Refuses an output directory that holds an earlier run's files, unless ``force``.

    Raises:
        FileExistsError: ``<dir> already holds a sim2sim run (trace.csv, ...); pass
            --force to overwrite it``.
    """
    held = [name for name in OUTPUTS if (Path(out_dir) / name).exists()]
    if held:
        refuse_existing(out_dir, force, f"a sim2sim run ({', '.join(held)})")


def run_sim2sim(controller: str, out_dir: str | Path,
                cfg: Sim2SimConfig | None = None) -> dict:
    """Runs a controller (a registry spec, e.g. ``onnx:DIR`` or ``qp``), writes the trace,
    plot, summary and video; returns the summary.

    A run whose simulation diverges (:func:`~hybrid_recovery.sim.divergence.divergence`)
    stops there: the summary's ``diverged`` is true, ``divergence`` says why and when,
    and ``upright_at_end`` is false.

    Raises:
        ValueError: an unknown controller or a policy that does not fit (nothing is
            written).
        SimulationDiverged: the start state is not finite (nothing is written).
    """
    cfg = cfg or Sim2SimConfig()
    safety = SafetyConfig(SafetyLimits.from_robot(cfg.model_path), skip_startup=not cfg.startup)
    runner = make_runner(controller, safety.q_ref_range_factor)  # refuses a bad spec first
    safety = replace(safety, period_s=runner.period_s)
    robot_cfg = SimRobotConfig(model_path=cfg.model_path, physics_dt=0.001,
                               rotor_inertia=cfg.rotor_inertia)
    if cfg.start_qpos is None:
        qpos, qvel = start_state(cfg.model_path, cfg.pose, robot_cfg.physics_dt, cfg.seed,
                                 cfg.rotor_inertia)
    else:
        qpos, qvel = np.asarray(cfg.start_qpos, dtype=float), None
    robot = SimRobot(robot_cfg, qpos, qvel)
    if (diverged := divergence(robot.data)) is not None:
        raise SimulationDiverged(f"the start state has diverged ({diverged})")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sm = SafetyStateMachine(safety)
    trace = BalanceTrace(RobotModel(robot.model))
    decimation = round(safety.period_s / robot_cfg.physics_dt)
    delay_steps = round(cfg.delay_s / robot_cfg.physics_dt)
    pending: deque[tuple[int, JointCommand]] = deque()
    angle = math.radians(cfg.push_direction_deg)
    push_vec = cfg.push_force * np.array([math.cos(angle), math.sin(angle), 0.0])
    video = _Video(robot, cfg) if cfg.video else None
    steps = round(cfg.seconds / robot_cfg.physics_dt)
    for k in range(steps):
        if k % decimation == 0:
            state = robot.state()
            policy = runner.step(state) if sm.phase is Phase.POLICY else None
            before = sm.phase
            cmd = sm.tick(robot.time, state, policy)
            if sm.phase is Phase.POLICY and before is not Phase.POLICY:
                runner.reset()
            if cmd is not None:
                pending.append((k + delay_steps, runner.command(cmd, sm.phase)))
            d = robot.data
            trace.record(robot.time, sm.phase.value, d.qpos, d.qvel,
                         projected_gravity(state.quat), float(np.linalg.norm(robot.push)))
        while pending and pending[0][0] <= k:
            robot.apply_command(pending.popleft()[1])
        pushing = cfg.push_time <= robot.time < cfg.push_time + cfg.push_duration
        robot.push = push_vec if pushing else np.zeros(3)
        t_step = robot.time
        robot.step(1)
        diverged = divergence_after_step(robot.model, robot.data, t_step,
                                         (k + 1) % decimation == 0 or k + 1 == steps)
        if diverged is not None:
            break
        if video is not None:
            video.maybe_capture()
    summary = _summary(trace, sm, cfg, diverged)
    trace.write_csv(out / "trace.csv")
    title = f"{Path(cfg.model_path).name if cfg.model_path else 'own model'}, {cfg.pose}"
    if cfg.push_force:
        title += f", push {cfg.push_force:.0f} N"
    trace.plot(out / "trace.png", title)
    if video is not None:
        summary["video"] = video.write(out / "video.mp4")
        if video.renderer is not None:
            summary["renderer"] = video.renderer.backend_name
    atomic_write_text(json.dumps(summary, indent=2), out / "summary.json")
    return summary


def _summary(trace: BalanceTrace, sm: SafetyStateMachine, cfg: Sim2SimConfig,
             diverged: str | None = None) -> dict:
    """The run's figures; a run whose simulation diverged (``diverged``: why and when) is
    never upright at its end."""
    com_z, tilt, t = trace.column("com_z"), trace.column("tilt_deg"), trace.column("t")
    upright = com_z > UPRIGHT_COM_HEIGHT
    first_up = float(t[np.argmax(upright)]) if upright.any() else None
    config = asdict(cfg)
    if cfg.start_qpos is not None:
        config["start_qpos"] = np.asarray(cfg.start_qpos).tolist()
    return {
        "config": config, "fault": None if sm.fault is None else sm.fault.value,
        "fault_detail": sm.fault_detail, "final_phase": sm.phase.value,
        "final_com_height": float(com_z[-1]), "min_com_height": float(com_z.min()),
        "max_tilt_deg": float(tilt.max()), "final_tilt_deg": float(tilt[-1]),
        "upright_at_end": diverged is None and bool(upright[-1]),
        "first_upright_time": first_up,
        "transitions": [(tt, p.value, why) for tt, p, why in sm.transitions],
        "diverged": diverged is not None, "divergence": diverged,
    }


class _Video:
    """Frames of :class:`hybrid_recovery.sim.render.BalanceRenderer` (robot, CoM, capture
    point, support polygons, push arrow) at ``fps``, written with imageio."""

    def __init__(self, robot: SimRobot, cfg: Sim2SimConfig) -> None:
        from hybrid_recovery.sim.render import BalanceRenderer

        self.robot, self.dt = robot, 1.0 / cfg.fps
        self.frames: list = []
        self.next_t = 0.0
        self.error = ""
        try:
            self.renderer: BalanceRenderer | None = BalanceRenderer(
                cfg.model_path, cfg.width, cfg.height)
        except (RuntimeError, ValueError) as err:  # keep the run, say why
            self.renderer, self.error = None, f"no video: {err}"

    def maybe_capture(self) -> None:
        from hybrid_recovery.sim.render import balance_overlay

        if self.renderer is None or self.robot.time + 1e-9 < self.next_t:
            return
        self.next_t += self.dt
        robot = self.robot
        overlay = balance_overlay(robot.model, robot.data, robot.push)
        self.frames.append(self.renderer.frame(robot.data.qpos, overlay, self.dt).copy())

    def write(self, path: Path) -> str:
        if self.renderer is None or not self.frames:
            return self.error or "no frames"
        import imageio.v2 as imageio

        self.renderer.close()
        with atomic_path(path) as tmp:
            imageio.mimwrite(tmp, self.frames, fps=round(1.0 / self.dt), macro_block_size=8)
        return str(path)
