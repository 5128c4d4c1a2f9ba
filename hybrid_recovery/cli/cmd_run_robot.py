"""``hybrid-recovery run-robot``: safety state machine + a controller over DDS.

Zero torque → interpolate to the default pose → hold → controller (``--controller NAME``,
or ``--policy DIR``: the ONNX policy at 50 Hz); damping on Ctrl-C, at the end of
``--seconds``, or on any fault. Prints a JSON report and exits 1 after a fault;
when the loop itself failed (damping was sent first) prints ``error: <cause>`` and exits
1. Read deploy/README.md before using it on the robot.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import CONTROLLER_HELP, non_negative, positive


def _run_robot(args: argparse.Namespace) -> int:
    from hybrid_recovery.deploy.bridge import ControllerError, run_controller
    from hybrid_recovery.deploy.state_machine import SafetyConfig
    from hybrid_recovery.robot.limits import SafetyLimits

    safety = SafetyConfig(SafetyLimits.from_robot(), zero_torque_s=args.zero_torque_s,
                          interpolate_s=args.interpolate_s, hold_s=args.hold_s,
                          joint_margin=args.joint_margin,
                          stale_timeout_s=args.stale_timeout_s, overrun_s=args.overrun_s)
    try:
        report = run_controller(args.controller or f"onnx:{args.policy}", args.domain,
                                args.interface, args.seconds, safety, args.wait_timeout_s,
                                realtime=args.realtime)
    except ControllerError as err:  # a fault of the loop: damping was sent, exit as a fault
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(json.dumps(dataclasses.asdict(report)))
    return 0 if report.fault is None else 1


def _configure(p: argparse.ArgumentParser) -> None:
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--policy", help="directory with policy.onnx and policy.json")
    which.add_argument("--controller", help=f"run this controller instead: {CONTROLLER_HELP}; "
                       "a torque controller sends feed-forward torque with kp = 0")
    p.add_argument("--domain", type=int, default=0, help="DDS domain id (the robot uses 0)")
    p.add_argument("--interface", default="lo", help="network interface, e.g. eth0 or lo")
    p.add_argument("--seconds", type=positive, default=None,
                   help="stop (damping) this long after the first state; default: Ctrl-C")
    p.add_argument("--zero-torque-s", type=non_negative, default=0.5)
    p.add_argument("--interpolate-s", type=positive, default=2.0)
    p.add_argument("--hold-s", type=non_negative, default=1.0)
    p.add_argument("--joint-margin", type=non_negative, default=0.1,
                   help="allowed excursion beyond the joint ranges before a fault [rad]")
    p.add_argument("--stale-timeout-s", type=positive, default=0.1,
                   help="no new state for this long is a fault [s]")
    p.add_argument("--overrun-s", type=non_negative, default=0.02,
                   help="a tick this much later than the control period (20 ms for a "
                        "policy) is a fault [s]")
    p.add_argument("--wait-timeout-s", type=positive, default=10.0)
    p.add_argument("--realtime", action="store_true", help="ask for SCHED_FIFO priority")


_run_robot.configure = _configure  # type: ignore[attr-defined]
command("run-robot", "The robot's controller: safety state machine + a controller (the ONNX "
        "policy at 50 Hz) over rt/lowstate and rt/lowcmd.")(_run_robot)
