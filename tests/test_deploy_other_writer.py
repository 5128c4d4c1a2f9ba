"""Two writers of ``rt/lowcmd`` on one DDS domain: a second ``run-robot`` refuses to
command (one line, naming the first's pid), and a controller whose robot receives another
writer's commands goes to damping with the fault ``other_writer``; a second ``sim-robot``
refuses to publish ``rt/lowstate`` beside the first.

Processes over loopback as in ``test_deploy_loopback.py``; every wait is on a measured
event (the first command seen on the domain, a process's exit) with a generous deadline.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DEADLINE_S = 90.0
"""Every process and every wait must finish within this (hard kill after)."""


def _spawn(subcommand: str, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "hybrid_recovery.cli.main", subcommand,
                             *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


ROGUE = ("import sys, time\n"
         "from hybrid_recovery.deploy import protocol as p\n"
         "rogue = p.low_cmd_publisher(p.DdsChannel(int(sys.argv[1]), 'lo'))\n"
         "start = time.monotonic()\n"
         "while time.monotonic() - start < 120:\n"
         "    rogue.write(p.with_crc(p.default_low_cmd()))\n"
         "    time.sleep(0.02)\n")
"""Another program writing limp commands on rt/lowcmd at 50 Hz (no user data)."""


def _rogue(domain: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-c", ROGUE, str(domain)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


WATCH = ("import sys\n"
         "from hybrid_recovery.deploy import protocol as p\n"
         "topic = {'lowcmd': p.low_cmd_subscriber, 'lowstate': p.low_state_subscriber}\n"
         "reader = topic[sys.argv[2]](p.DdsChannel(int(sys.argv[1]), 'lo'))\n"
         "print('seen' if reader.wait_for(float(sys.argv[3])) is not None else 'none', "
         "flush=True)\n")
"""A reader of rt/lowcmd or rt/lowstate in its own process (a DDS participant left in the
test process crashed later tests' participants): prints ``seen`` at the first sample."""


def _seen(domain: int, topic: str) -> bool:
    """Whether a sample of ``topic`` (``lowcmd``, ``lowstate``) arrives on ``domain``
    within :data:`DEADLINE_S`, read by a process of its own."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", WATCH, str(domain), topic, str(DEADLINE_S)],
                          env=env, capture_output=True, text=True, timeout=DEADLINE_S + 30)
    return done.stdout.strip() == "seen"


def _finish(proc: subprocess.Popen, deadline: float) -> tuple[int, str, str]:
    try:
        out, err = proc.communicate(timeout=max(deadline - time.monotonic(), 0.1))
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"{proc.args[3:5]} did not finish in time: {err[-2000:]}")
    return proc.returncode, out, err


@pytest.mark.dds
def test_a_second_controller_refuses_and_foreign_commands_bring_damping(dds_domain, tmp_path):
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    from hybrid_recovery.training.stand_in import write_stand_in_policy

    policy = write_stand_in_policy(tmp_path / "zero", "zero")
    domain = dds_domain
    procs = []
    try:
        procs.append(_spawn("sim-robot", "--domain", str(domain), "--interface", "lo",
                            "--seconds", "80", "--idle-exit-s", "0.3"))
        procs.append(first := _spawn(
            "run-robot", "--policy", str(policy), "--domain", str(domain), "--interface",
            "lo", "--seconds", "60", "--wait-timeout-s", "60", "--zero-torque-s", "0.3",
            "--overrun-s", "0.5", "--stale-timeout-s", "0.5"))
        deadline = time.monotonic() + DEADLINE_S
        assert _seen(domain, "lowcmd"), "the first controller never commanded"

        procs.append(second := _spawn(
            "run-robot", "--policy", str(policy), "--domain", str(domain), "--interface",
            "lo", "--seconds", "5", "--wait-timeout-s", "60"))
        code, out, err = _finish(second, deadline)
        assert code == 2 and out == ""
        assert err.strip().splitlines()[-1] == (
            f"error: another writer is on rt/lowcmd (domain {domain}, interface lo: "
            f"hybrid-recovery controller pid {first.pid}); refusing to command the robot: "
            "stop it first")
        assert first.poll() is None, "a refused controller must not disturb the first"

        procs.append(rogue := _rogue(domain))  # another program commanding the robot
        code, out, err = _finish(first, deadline)
        rogue.kill()
        report = json.loads(out.strip().splitlines()[-1])
        assert code == 1, err[-2000:]
        assert report["fault"] == "other_writer"
        assert report["fault_detail"].startswith("another writer commands on rt/lowcmd "
                                                 "(participant ")
        phases = [phase for _, phase, _ in report["transitions"]]
        assert phases[0] == "zero_torque" and phases[-1] == "damping"
        assert phases.count("damping") == 1
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.communicate()


@pytest.mark.dds
def test_a_second_simulated_robot_refuses_to_publish(dds_domain: int):
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")

    domain = dds_domain
    procs = []
    try:
        procs.append(first := _spawn("sim-robot", "--domain", str(domain), "--interface",
                                     "lo", "--seconds", "60"))
        deadline = time.monotonic() + DEADLINE_S
        assert _seen(domain, "lowstate"), "the first robot never published"
        procs.append(second := _spawn("sim-robot", "--domain", str(domain), "--interface",
                                      "lo", "--seconds", "5"))
        code, out, err = _finish(second, deadline)
        assert code == 2 and out == ""
        assert err.strip().splitlines()[-1] == (
            f"error: another writer is on rt/lowstate (domain {domain}, interface lo: "
            f"hybrid-recovery robot pid {first.pid}); refusing to publish a second robot's "
            "state: stop it first")
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
            proc.communicate()


def test_another_writer_is_a_final_damping_fault():
    from hybrid_recovery.deploy.robot_io import LowStateReading
    from hybrid_recovery.deploy.state_machine import (
        Fault,
        Phase,
        SafetyConfig,
        SafetyStateMachine,
    )
    from hybrid_recovery.robot import constants
    from hybrid_recovery.robot.limits import SafetyLimits

    sm = SafetyStateMachine(SafetyConfig(SafetyLimits.from_robot()))
    state = LowStateReading(1, np.array([1.0, 0, 0, 0]), np.zeros(3),
                            constants.DEFAULT_JOINT_POS.copy(), np.zeros(27), np.zeros(27))
    assert sm.tick(0.0, state) is not None and sm.phase is Phase.ZERO_TORQUE
    cmd = sm.fail_safe(0.02, "another writer commands on rt/lowcmd (pid 7)",
                       Fault.OTHER_WRITER)
    assert sm.phase is Phase.DAMPING and sm.fault is Fault.OTHER_WRITER
    assert not cmd.kp.any() and (cmd.kd > 0).all()
    assert sm.transitions[-1][1:] == (Phase.DAMPING, "other_writer: another writer commands "
                                                     "on rt/lowcmd (pid 7)")
    assert sm.tick(0.04, state).kp.sum() == 0.0 and sm.phase is Phase.DAMPING
