"""The two ends of the robot link over DDS: the 50 Hz controller and the simulated robot.

Controller (:func:`run_controller`): every control period (20 ms for a policy, the
controller's physics step for the others) take the newest ``LowState_``, run the
controller when the safety state machine is in POLICY, let the machine produce the
command, send it in the controller's output kind (:mod:`~.controller_runner`: position
targets with gains, or feed-forward torque with kp = 0), publish it as ``LowCmd_``
(``mode_machine`` echoed from the state, ``mode_pr`` = 0). On the real H1-2 the same loop
runs against the robot's own ``rt/lowstate``/``rt/lowcmd``.

Simulated robot (:func:`serve_sim_robot`): MuJoCo at 1 kHz under the newest valid
``LowCmd_``, publishing ``LowState_`` every 2 ms (500 Hz) with an increasing tick.

Both use :class:`~hybrid_recovery.deploy.fast_dds.FastLink` (wire bytes, ≈ 60 µs per
message instead of ≈ 1.3 ms for cyclonedds' Python serialiser).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from hybrid_recovery.deploy.controller_runner import make_runner
from hybrid_recovery.deploy.fast_dds import FastLink
from hybrid_recovery.deploy.robot_io import JointCommand, LowStateReading
from hybrid_recovery.deploy.state_machine import Fault, Phase, SafetyConfig, SafetyStateMachine
from hybrid_recovery.deploy.timing import LoopStats, PeriodicClock, try_realtime
from hybrid_recovery.deploy.wire import decode_low_state, encode_low_cmd
from hybrid_recovery.robot.limits import SafetyLimits

if TYPE_CHECKING:
    from hybrid_recovery.deploy.sim_robot import SimRobot, SimRobotConfig

NO_STATE_HINT = (
    "no LowState_ on rt/lowstate within {timeout} s (domain {domain}, interface {iface}). "
    "Is the robot (or hybrid-recovery sim-robot) running on this domain and interface? On the "
    "real H1-2: its stack uses cyclonedds 0.10.x, which does not talk to cyclonedds 11 "
    "(see deploy/README.md)."
)


WRITER_WATCH_S = 0.5
"""The controller watches ``rt/lowcmd`` for another writer for this long after joining the
domain before it commands [s]: DDS discovery of the peers takes tens of milliseconds on
one host, and the robot's state can arrive first."""


class OtherWriterError(RuntimeError):
    """Another process writes the topic this side would write (``rt/lowcmd`` for the
    controller, ``rt/lowstate`` for the simulated robot) on this domain: nothing was sent."""


class ControllerError(RuntimeError):
    """The controller's loop failed; damping was sent first. The message names the cause
    (also kept as ``__cause__``)."""


@dataclass
class ControllerReport:
    """What a controller run saw and did."""

    scheduling: str
    transitions: list[tuple[float, str, str]]
    fault: str | None
    fault_detail: str
    states_received: int
    bad_crc_states: int
    ticks: list[int]
    """Tick of every newly decoded state, in order of use."""
    commands_sent: int
    seconds: float
    stats: dict[str, float] = field(default_factory=dict)


def run_controller(controller: str, domain_id: int = 0, interface: str = "lo",
                   seconds: float | None = None, safety: SafetyConfig | None = None,
                   wait_timeout_s: float = 10.0, damping_s: float = 0.5,
                   realtime: bool = False,
                   writer_watch_s: float = WRITER_WATCH_S) -> ControllerReport:
    """Runs a controller until ``seconds`` after the first state, a fault, or Ctrl-C.

    ``controller`` is a registry spec (:func:`hybrid_recovery.controllers.make`), e.g.
    ``onnx:DIR`` for an export directory or ``hybrid``; the state machine ticks at its
    runner's period (``safety.period_s`` is replaced by it).

    Then it sends damping commands for ``damping_s`` and returns. An exception inside
    the loop (a malformed message, an inference error, a bug) is a fault too: damping
    commands are sent for ``damping_s`` first, then :class:`ControllerError` is raised
    with the cause.

    Before its first command it watches ``rt/lowcmd`` for another writer until
    ``writer_watch_s`` after joining the domain, and refuses to command if there is one
    (:class:`OtherWriterError`); commands of another writer arriving later are a fault
    (:attr:`Fault.OTHER_WRITER`: damping).

    Raises:
        ValueError: an unknown controller, or
            :class:`~.policy_runner.PolicyMismatchError`: the policy does not match the
            robot (checked first).
        TimeoutError: no state arrived within ``wait_timeout_s``.
        OtherWriterError: another process writes ``rt/lowcmd`` (nothing was sent).
        ControllerError: the loop failed (after damping was sent).
    """
    safety = safety or SafetyConfig(SafetyLimits.from_robot())
    runner = make_runner(controller, safety.q_ref_range_factor)
    sm = SafetyStateMachine(dataclasses.replace(safety, period_s=runner.period_s))
    link = FastLink(domain_id, interface, "controller")
    t_joined = time.monotonic()
    scheduling = try_realtime() if realtime else "normal"
    if link.wait_for(wait_timeout_s) is None and link.latest() is None:
        raise TimeoutError(NO_STATE_HINT.format(timeout=wait_timeout_s, domain=domain_id,
                                                iface=interface))
    _refuse_other_writers(link, t_joined + writer_watch_s, domain_id, interface)
    clock = PeriodicClock(sm.config.period_s)
    stats = LoopStats(sm.config.period_s)
    state: LowStateReading | None = None
    seen, bad, ticks, sent = 0, 0, [], 0
    t_start, t_damping = clock.t0, None
    try:
        while t_damping is None or clock.deadline - t_damping < damping_s:
            deadline = clock.deadline
            now = clock.wait()
            raw = link.latest()
            if raw is not None and raw.count != seen:
                seen = raw.count
                decoded = decode_low_state(raw.wire, raw.t_receive)
                if decoded.crc_ok:
                    state = decoded
                    ticks.append(decoded.tick)
                else:
                    bad += 1
            policy = None
            if sm.phase is Phase.POLICY and state is not None:
                t_inf = time.monotonic()
                policy = runner.step(state)
                stats.inference.append(time.monotonic() - t_inf)
            before = sm.phase
            others = link.other_writes() if before is not Phase.DAMPING else []
            cmd: JointCommand | None
            if others:
                cmd = sm.fail_safe(now, f"another writer commands on rt/lowcmd "
                                        f"({', '.join(others)})", Fault.OTHER_WRITER)
            else:
                cmd = sm.tick(now, state, policy)
            if sm.phase is Phase.POLICY and before is not Phase.POLICY:
                runner.reset()
            if cmd is not None and state is not None:
                link.write(encode_low_cmd(runner.command(cmd, sm.phase), state.mode_machine))
                sent += 1
            stats.wake.append(now)
            stats.deadline.append(deadline)
            stats.compute.append(time.monotonic() - now)
            if seconds is not None and now - t_start >= seconds:
                sm.request_stop("run time over")
            if sm.phase is Phase.DAMPING and t_damping is None:
                t_damping = now
    except KeyboardInterrupt:
        sm.request_stop("interrupted")
        for _ in range(int(damping_s / sm.config.period_s)):
            now = clock.wait()
            cmd = sm.tick(now, state)
            if cmd is not None and state is not None:
                link.write(encode_low_cmd(cmd, state.mode_machine))
    except Exception as err:
        cause = f"{type(err).__name__}: {err}"
        damped = _send_damping(link, sm, state, cause, damping_s)
        raise ControllerError(
            f"the control loop failed {time.monotonic() - t_start:.2f} s after the first "
            f"state ({cause}); {damped} damping commands sent") from err
    return ControllerReport(
        scheduling=scheduling,
        transitions=[(t - t_start, p.value, why) for t, p, why in sm.transitions],
        fault=None if sm.fault is None else sm.fault.value, fault_detail=sm.fault_detail,
        states_received=link.count, bad_crc_states=bad, ticks=ticks, commands_sent=sent,
        seconds=time.monotonic() - t_start, stats=stats.summary())


def _refuse_other_writers(link: FastLink, until: float, domain_id: int, interface: str,
                          refusing: str = "refusing to command the robot") -> None:
    """Raises :class:`OtherWriterError` if another writer of the link's topic is matched
    (or its messages arrive) before ``until`` (``time.monotonic()``) or now."""
    while True:
        others = sorted(set(link.other_writers()) | set(link.other_writes()))
        if others:
            raise OtherWriterError(
                f"another writer is on {link.out_topic} (domain {domain_id}, interface "
                f"{interface}: {', '.join(others)}); {refusing}: stop it first")
        if time.monotonic() >= until:
            return
        time.sleep(0.01)


def _send_damping(link: FastLink, sm: SafetyStateMachine, state: LowStateReading | None,
                  cause: str, damping_s: float) -> int:
    """Damping (kp = 0) for ``damping_s`` after a failure of the loop; returns how many
    commands went out. Nothing is sent before the first state (nothing was sent then)."""
    if state is None:
        return 0
    cmd = sm.fail_safe(time.monotonic(), cause)
    wire = encode_low_cmd(cmd, state.mode_machine)
    sent = 0
    for _ in range(max(1, int(round(damping_s / sm.config.period_s)))):
        try:
            link.write(wire)
        except Exception:  # noqa: BLE001 - the link itself failed: nothing more to send
            break
        sent += 1
        time.sleep(sm.config.period_s)
    return sent


@dataclass
class SimRobotReport:
    """What the simulated robot saw."""

    scheduling: str
    published: int
    seconds: float
    commands_received: int
    """Commands DDS delivered; the loop applies the newest at each step, so a command
    followed by another within one step (2 ms, or a stall of the loop) is superseded."""
    commands_accepted: int
    commands_rejected: int
    first_tick: int
    last_tick: int
    standing: dict[str, float] | None
    """Pelvis height [m] and torso tilt [deg] when the last active command (any kp > 0,
    or a feed-forward torque) was replaced by a limp or damping one, or at the end."""
    final: dict[str, float]
    stats: dict[str, float] = field(default_factory=dict)


def serve_sim_robot(cfg: SimRobotConfig | None = None, domain_id: int = 0,
                    interface: str = "lo", seconds: float = 30.0, idle_exit_s: float = 1.0,
                    realtime: bool = False) -> SimRobotReport:
    """Runs the simulated robot in real time for ``seconds``, or until no command arrived
    for ``idle_exit_s`` after the controller went to damping (all kp = 0, no torque).

    Raises:
        OtherWriterError: another robot publishes ``rt/lowstate`` on the domain (watched
            for :data:`WRITER_WATCH_S` before the first state is published).
    """
    from hybrid_recovery.deploy.sim_robot import SimRobot

    robot = SimRobot(cfg)
    link = FastLink(domain_id, interface, "robot")
    _refuse_other_writers(link, time.monotonic() + WRITER_WATCH_S, domain_id, interface,
                          "refusing to publish a second robot's state")
    scheduling = try_realtime() if realtime else "normal"
    substeps = 2
    clock = PeriodicClock(substeps * robot.cfg.physics_dt)
    stats = LoopStats(clock.period)
    seen, published, first_tick = 0, 0, robot.tick
    standing: dict[str, float] | None = None
    t_last_cmd, positioned = None, False
    while True:
        deadline = clock.deadline
        now = clock.wait()
        if now - clock.t0 >= seconds:
            break
        raw = link.latest()
        if raw is not None and raw.count != seen:
            seen = raw.count
            if robot.apply_command_wire(raw.wire) and robot.command is not None:
                t_last_cmd = now
                active = bool(np.any(robot.command.kp > 0) or np.any(robot.command.tau != 0))
                if positioned and not active and standing is None:
                    standing = _pose(robot)
                positioned = positioned or active
        robot.step(substeps)
        link.write(robot.state_wire())
        published += 1
        stats.wake.append(now)
        stats.deadline.append(deadline)
        stats.compute.append(time.monotonic() - now)
        if (standing is not None and t_last_cmd is not None
                and now - t_last_cmd > idle_exit_s):
            break
    return SimRobotReport(
        scheduling=scheduling, published=published, seconds=time.monotonic() - clock.t0,
        commands_received=link.count, commands_accepted=robot.accepted,
        commands_rejected=robot.rejected,
        first_tick=first_tick, last_tick=robot.tick,
        standing=standing if standing is not None else (_pose(robot) if positioned else None),
        final=_pose(robot), stats=stats.summary())


def _pose(robot: SimRobot) -> dict[str, float]:
    return {"time": robot.time, "pelvis_height": robot.base_height(),
            "torso_tilt_deg": robot.torso_tilt_deg(), "gantry": float(robot.gantry_on)}
