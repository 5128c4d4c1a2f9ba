"""A torque controller on the robot link: ``hybrid`` over loopback DDS against ``sim-robot``.

Two processes, as on the robot: ``hybrid-recovery sim-robot`` and the controller loop
(:func:`~hybrid_recovery.deploy.bridge.run_controller` with ``"hybrid"``, its commands
recorded where they are encoded). The loop runs the unchanged safety sequence, zero torque
→ interpolate → hold → controller → damping. The policy acts first, as joint targets with
the drivers' gains; once the robot stands the QP takes over, and its commands are
feed-forward torque with kp = kd = 0 and |τ| ≤ τ_max; no command carries both. The
simulated robot must accept every command and stand when damping begins.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest
from test_deploy_loopback import ROOT, TIMEOUT_S, _report, _spawn

from hybrid_recovery.policy import is_shipped

_CONTROLLER = """
import dataclasses, json, sys
import numpy as np
from hybrid_recovery.deploy import bridge
from hybrid_recovery.deploy.state_machine import SafetyConfig
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits

sent, runners = [], []
encode, make_runner = bridge.encode_low_cmd, bridge.make_runner
bridge.encode_low_cmd = lambda cmd, mode: sent.append(cmd) or encode(cmd, mode)
bridge.make_runner = lambda *args: runners.append(make_runner(*args)) or runners[-1]
# a loaded test machine: allow 200 ms stalls (defaults: 20 / 100 ms)
safety = SafetyConfig(SafetyLimits.from_robot(), zero_torque_s=0.1, interpolate_s=1.0,
                      hold_s=0.5, overrun_s=0.2, stale_timeout_s=0.3)
report = bridge.run_controller("hybrid", int(sys.argv[2]), "lo", seconds=8.0, safety=safety,
                               wait_timeout_s=90.0)
torque = [c for c in sent if np.any(c.tau != 0)]
stiff = [c for c in sent if np.any(c.kp > 0)]
print(json.dumps({
    "report": dataclasses.asdict(report), "period_s": runners[0].period_s,
    "output": runners[0].output, "torque_commands": len(torque),
    "torque_gains": float(max((max(c.kp.max(), c.kd.max()) for c in torque), default=0.0)),
    "torque_ratio": float(max(((np.abs(c.tau) / constants.EFFORT_LIMITS).max()
                               for c in torque), default=0.0)),
    "stiff_commands": len(stiff),
    "stiff_torque": float(max((np.abs(c.tau).max() for c in stiff), default=0.0)),
    "switches": [kind for _, kind, _ in runners[0].controller.info()["switches"]],
    "messages": [m for _, _, m in runners[0].controller.info()["switches"]]}))
"""


@pytest.mark.dds
@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_hybrid_sends_torques_with_kp_zero_over_loopback(dds_domain: int):
    pytest.importorskip("cyclonedds", reason="cyclonedds (extra 'deploy') not installed")
    domain = str(dds_domain)
    robot = _spawn("sim-robot", "--domain", domain, "--interface", "lo", "--gantry-s", "1.2",
                   "--seconds", "60")
    controller = subprocess.Popen(  # argv[3] names it in _report's messages
        [sys.executable, "-c", _CONTROLLER, "controller", domain], text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE)
    deadline = time.monotonic() + TIMEOUT_S
    ctrl = _report(controller, deadline, [robot])
    rob = _report(robot, deadline, [])

    report = ctrl["report"]
    assert report["fault"] is None, (report["fault_detail"], report["transitions"])
    assert [p for _, p, _ in report["transitions"]] == [
        "zero_torque", "interpolate", "hold", "policy", "damping"]
    assert ctrl["period_s"] == 0.002 and ctrl["output"] == "torque"
    assert "to_qp" in ctrl["switches"], ctrl["messages"]
    assert ctrl["torque_commands"] >= 250  # the QP's, ≥ 0.5 s at 2 ms
    assert ctrl["torque_gains"] == 0.0 and ctrl["torque_ratio"] <= 1.0
    assert ctrl["stiff_commands"] > 0 and ctrl["stiff_torque"] == 0.0  # start-up, policy

    assert rob["commands_rejected"] == 0
    standing = rob["standing"]
    assert standing["gantry"] == 0.0, "the gantry was never released"
    assert standing["pelvis_height"] > 0.95 and standing["torso_tilt_deg"] < 20.0, standing
