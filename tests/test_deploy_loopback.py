"""The controller and the simulated robot as two processes over loopback DDS.

``hybrid-recovery sim-robot`` (MuJoCo 1 kHz, LowState_ at 500 Hz, robot on a gantry for 2.5
s after the first command) and ``hybrid-recovery run-robot`` (state machine + a zero-action ONNX
stand-in, 4 s) on ``lo`` with a random domain id. The controller must see states with
increasing ticks and go through zero torque → interpolate → hold → policy → damping; the
robot must accept every command it got (valid CRC) and be standing when damping begins.

Every wait is on an event (the controller waits for the robot's first state, the robot for
the first command), with deadlines generous for a loaded machine; the robot applies the
newest command at each 2 ms step, so a loaded machine supersedes some: what reaches the
robot is counted where DDS delivers it.
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
TIMEOUT_S = 120.0
"""Both processes together must finish within this (hard kill after)."""


def _spawn(subcommand: str, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "hybrid_recovery.cli.main", subcommand,
                             *args], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _report(proc: subprocess.Popen, deadline: float, others: list[subprocess.Popen]) -> dict:
    try:
        out, err = proc.communicate(timeout=max(deadline - time.monotonic(), 0.1))
    except subprocess.TimeoutExpired:
        for p in [proc, *others]:
            p.kill()
            p.communicate()
        pytest.fail(f"{proc.args[3]} did not finish within {TIMEOUT_S} s")
    assert proc.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.dds
def test_controller_stands_the_simulated_robot_up_over_loopback(dds_domain, tmp_path):
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    from hybrid_recovery.training.stand_in import write_stand_in_policy

    policy = write_stand_in_policy(tmp_path / "zero", "zero")
    domain = str(dds_domain)
    robot = _spawn("sim-robot", "--domain", domain, "--interface", "lo", "--gantry-s", "2.5",
                   "--seconds", "100", "--idle-exit-s", "0.3")
    # zero torque 0.3 s, interpolate 2 s, hold 0.5 s (gantry released at 2.5 s), policy
    # from 2.8 s, damping at 4 s
    controller = _spawn("run-robot", "--policy", str(policy), "--domain", domain,
                        "--interface", "lo", "--seconds", "4", "--zero-torque-s", "0.3",
                        "--hold-s", "0.5", "--wait-timeout-s", "90",
                        # this test is about the protocol and the sequence: on a shared,
                        # loaded test machine allow 200 ms stalls (defaults: 20 / 100 ms)
                        "--overrun-s", "0.2", "--stale-timeout-s", "0.3")
    deadline = time.monotonic() + TIMEOUT_S
    ctrl = _report(controller, deadline, [robot])
    rob = _report(robot, deadline, [])

    ticks = ctrl["ticks"]
    assert len(ticks) >= 150, f"controller used only {len(ticks)} states"
    assert all(b > a for a, b in zip(ticks, ticks[1:], strict=False)), "ticks not increasing"
    assert ctrl["states_received"] >= 1000 and ctrl["bad_crc_states"] == 0
    assert [p for _, p, _ in ctrl["transitions"]][:4] == [
        "zero_torque", "interpolate", "hold", "policy"], ctrl["transitions"]
    assert [p for _, p, _ in ctrl["transitions"]] == [
        "zero_torque", "interpolate", "hold", "policy", "damping"]
    assert ctrl["fault"] is None, ctrl["fault_detail"]
    assert ctrl["fault_detail"] == "run time over"

    assert rob["commands_rejected"] == 0
    assert rob["commands_received"] >= 0.9 * ctrl["commands_sent"] >= 150
    assert 0 < rob["commands_accepted"] <= rob["commands_received"]
    standing = rob["standing"]
    assert standing["gantry"] == 0.0, "the gantry was never released"
    assert standing["pelvis_height"] > 0.98 and standing["torso_tilt_deg"] < 8.0, standing
    assert rob["last_tick"] > ticks[-1]


def test_no_robot_gives_a_clear_timeout(dds_domain, tmp_path):
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    from hybrid_recovery.deploy.bridge import run_controller
    from hybrid_recovery.training.stand_in import write_stand_in_policy

    policy = write_stand_in_policy(tmp_path / "zero", "zero")
    domain = dds_domain
    with pytest.raises(TimeoutError, match=rf"^no LowState_ on rt/lowstate within 0.3 s "
                                           rf"\(domain {domain}, interface lo\)"):
        run_controller(f"onnx:{policy}", domain, "lo", seconds=1.0, wait_timeout_s=0.3)
