"""Two processes on loopback: a fake robot publishes ``LowState_``, a controller answers.

The robot publishes ``rt/lowstate`` with an increasing ``tick`` and a valid CRC at up to
500 Hz; the controller checks both and answers each state with a ``LowCmd_`` on
``rt/lowcmd`` that echoes the tick in ``reserve[0]``; the robot checks those. Each side
runs as ``python tests/test_dds_loopback.py ROLE DOMAIN`` and prints a JSON report.

No step waits a fixed time for the other side: the robot publishes until it has received
``ECHOES`` commands, then marks its last states done (``mode_machine`` = ``DONE``), on
which the controller stops; only the deadlines, generous for a loaded machine, are times.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PERIOD_S = 0.002  # 500 Hz
ECHOES = 100
"""Commands the robot receives before it stops."""
DONE = 255
"""``mode_machine`` of the robot's last states: the controller stops on it."""
DONE_STATES = 25
"""How many done states the robot publishes (best effort: one is enough)."""
DEADLINE_S = 60.0  # either side gives up waiting for the other after this long
IDLE_S = 10.0  # the controller stops after this long without a state (no done seen)
SUBPROCESS_TIMEOUT_S = 120.0


def run_robot(domain_id: int) -> dict:
    """Publish states until ``ECHOES`` commands have come back, then ``DONE_STATES``
    done states; report the commands."""
    from hybrid_recovery.deploy import protocol as p

    channel = p.DdsChannel(domain_id, "lo")
    pub, sub = p.low_state_publisher(channel), p.low_cmd_subscriber(channel)
    start = time.monotonic()
    seen, echoed, bad_crc, done = 0, [], 0, 0
    tick = 0
    while time.monotonic() - start < DEADLINE_S and done < DONE_STATES:
        t_next = time.monotonic() + PERIOD_S
        state = p.default_low_state()
        state.tick = tick
        state.motor_state[3].q = tick * 1e-3
        if len(echoed) >= ECHOES:
            state.mode_machine = DONE
            done += 1
        pub.write(p.with_crc(state))
        tick += 1
        got = sub.latest()
        if got is not None and got.count > seen:
            seen = got.count
            echoed.append(got.msg.reserve[0])
            bad_crc += not p.crc_ok(got.msg)
        time.sleep(max(0.0, t_next - time.monotonic()))
    return {"published": tick, "echoed": echoed, "bad_crc": bad_crc, "last_tick": tick - 1}


def run_controller(domain_id: int) -> dict:
    """Answer each new state with a command until a done state (or ``IDLE_S`` without a
    state); report the states."""
    from hybrid_recovery.deploy import protocol as p

    channel = p.DdsChannel(domain_id, "lo")
    sub, pub = p.low_state_subscriber(channel), p.low_cmd_publisher(channel)
    first = sub.wait_for(DEADLINE_S)
    ticks, bad_crc, bad_q, got = [], 0, 0, first
    while got is not None:
        ticks.append(got.msg.tick)
        bad_crc += not p.crc_ok(got.msg)
        bad_q += abs(got.msg.motor_state[3].q - got.msg.tick * 1e-3) > 1e-6
        if got.msg.mode_machine == DONE:
            break
        cmd = p.default_low_cmd()
        cmd.reserve[0] = got.msg.tick
        cmd.motor_cmd[0].kp = 200.0
        pub.write(p.with_crc(cmd))
        got = sub.wait_for(IDLE_S)
    return {"ticks": ticks, "bad_crc": bad_crc, "bad_q": bad_q}


def _spawn(role: str, domain_id: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, str(Path(__file__).resolve()), role, str(domain_id)]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _report(proc: subprocess.Popen) -> dict:
    try:
        out, err = proc.communicate(timeout=SUBPROCESS_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"{proc.args[-2]} process timed out after {SUBPROCESS_TIMEOUT_S} s")
    assert proc.returncode == 0, err
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.dds
def test_lowstate_and_lowcmd_round_trip_between_two_processes(dds_domain: int) -> None:
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    domain_id = dds_domain
    controller = _spawn("controller", domain_id)
    robot = _spawn("robot", domain_id)
    states, cmds = _report(controller), _report(robot)

    ticks = states["ticks"]
    echoed = cmds["echoed"]
    assert len(echoed) >= ECHOES, f"robot received only {len(echoed)} commands"
    assert all(b > a for a, b in zip(ticks, ticks[1:], strict=False)), "ticks not increasing"
    assert states["bad_crc"] == 0 and states["bad_q"] == 0
    assert all(b >= a for a, b in zip(echoed, echoed[1:], strict=False))
    assert set(echoed) <= set(ticks) and max(echoed) <= cmds["last_tick"]
    assert cmds["bad_crc"] == 0


def test_an_unknown_interface_is_named(dds_domain: int) -> None:
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    import socket

    from hybrid_recovery.deploy.protocol import DdsChannel

    names = [name for _, name in socket.if_nameindex()]
    with pytest.raises(ValueError) as info:
        DdsChannel(dds_domain, "eth9")
    assert str(info.value) == (f"unknown network interface 'eth9' for DDS: this machine has "
                               f"{names}")


def test_domain_id_is_validated_before_touching_dds() -> None:
    from hybrid_recovery.deploy.protocol import DdsChannel

    with pytest.raises(ValueError, match=r"^domain_id must be in \[0, 232\], got 233$"):
        DdsChannel(233)


@pytest.mark.dds
def test_a_domain_stays_bound_to_its_first_interface(dds_domain: int) -> None:
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    domain_id = dds_domain
    code = (
        "from hybrid_recovery.deploy.protocol import DdsChannel\n"
        f"DdsChannel({domain_id}, 'lo'); DdsChannel({domain_id}, 'lo')\n"
        f"try:\n    DdsChannel({domain_id}, 'eth9')\nexcept ValueError as e:\n    print(e)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", code],
        env=env,
        capture_output=True,
        text=True,
        timeout=SUBPROCESS_TIMEOUT_S,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == (
        f"DDS domain {domain_id} is already bound to interface 'lo' in this process, not 'eth9'"
    )


if __name__ == "__main__":
    role, domain = sys.argv[1], int(sys.argv[2])
    report = run_robot(domain) if role == "robot" else run_controller(domain)
    print(json.dumps(report))
