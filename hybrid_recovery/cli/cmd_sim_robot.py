"""``hybrid-recovery sim-robot``: a simulated H1-2 on DDS for ``run-robot``.

MuJoCo at 1 kHz obeying ``rt/lowcmd``, ``rt/lowstate`` at 500 Hz. Prints a JSON report
when it ends (after ``--seconds``, or once the controller has gone to damping and stopped
sending).
"""

from __future__ import annotations

import argparse
import dataclasses
import json

from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import check_model, non_negative, positive


def _sim_robot(args: argparse.Namespace) -> int:
    from hybrid_recovery.deploy.bridge import serve_sim_robot
    from hybrid_recovery.deploy.sim_robot import SimRobotConfig

    check_model(args.model)
    cfg = SimRobotConfig(model_path=args.model, gantry_s=args.gantry_s)
    report = serve_sim_robot(cfg, args.domain, args.interface, args.seconds, args.idle_exit_s,
                             args.realtime)
    print(json.dumps(dataclasses.asdict(report)))
    return 0


def _configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--domain", type=int, default=1, help="DDS domain id (default 1)")
    p.add_argument("--interface", default="lo", help="network interface (default lo)")
    p.add_argument("--model", default=None, help="H1-2 MJCF (default: the project's model)")
    p.add_argument("--gantry-s", type=non_negative, default=3.5,
                   help="hang the pelvis this long after the first command; 0 = on the ground")
    p.add_argument("--seconds", type=positive, default=60.0, help="longest run time")
    p.add_argument("--idle-exit-s", type=positive, default=1.0,
                   help="exit this long after commands stop following damping")
    p.add_argument("--realtime", action="store_true", help="ask for SCHED_FIFO priority")


_sim_robot.configure = _configure  # type: ignore[attr-defined]
command("sim-robot", "A simulated H1-2 on DDS (MuJoCo 1 kHz, LowState_ at 500 Hz) for "
        "run-robot.")(_sim_robot)
