"""``hybrid-recovery sim2sim``."""

from __future__ import annotations

import argparse
from pathlib import Path

from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import (
    CONTROLLER_HELP,
    bounded,
    check_model,
    check_push_time,
    finite,
    integer,
    non_negative,
    positive,
)
from hybrid_recovery.evaluation.scenario import MAX_PUSH_FORCE

MAX_DELAY_MS = 1000.0
"""The longest actuation delay a run accepts [ms] (training draws 10–40 ms)."""


def _sim2sim(args: argparse.Namespace) -> int:
    from hybrid_recovery.deploy.sim2sim import Sim2SimConfig, check_output, run_sim2sim
    from hybrid_recovery.policy import resolve_policy

    check_push_time(args.push, args.push_time, args.seconds)
    check_model(args.model)
    out = Path(args.out)
    check_output(out, args.force)
    spec = args.controller
    if spec is None:
        policy = args.policy or "shipped"
        if policy != "zero":
            policy = resolve_policy(policy)
        else:
            from hybrid_recovery.training.stand_in import write_stand_in_policy

            policy = write_stand_in_policy(out / "stand_in_policy", "zero")
        spec = f"onnx:{policy}"
    cfg = Sim2SimConfig(model_path=args.model, rotor_inertia=args.rotor_inertia,
                        pose=args.pose, seconds=args.seconds,
                        push_force=args.push, push_direction_deg=args.push_angle,
                        push_time=args.push_time, push_duration=args.push_duration,
                        delay_s=args.delay_ms / 1e3, startup=args.startup,
                        video=not args.no_video, fps=args.fps)
    summary = run_sim2sim(spec, out, cfg)
    print(f"final CoM height {summary['final_com_height']:.3f} m, max tilt "
          f"{summary['max_tilt_deg']:.1f} deg, upright at end: {summary['upright_at_end']}, "
          f"fault: {summary['fault']}")
    if summary["diverged"]:
        print(f"diverged: {summary['divergence']}; the run stopped there")
    print(f"wrote {out / 'trace.csv'}, {out / 'trace.png'}, {out / 'summary.json'}"
          + (f", {summary['video']}" if "video" in summary else ""))
    if "renderer" in summary:
        print(f"renderer: {summary['renderer']}")
    return 0


def _configure(p: argparse.ArgumentParser) -> None:
    from hybrid_recovery.sim.initial_states import POSES

    which = p.add_mutually_exclusive_group()
    which.add_argument("--policy", default=None,
                       help="exported policy directory, 'shipped' (the default: the policy "
                            "shipped in models/policies/h1_2_recovery) or 'zero' for a "
                            "zero-action stand-in")
    which.add_argument("--controller", default=None,
                       help=f"run this controller instead: {CONTROLLER_HELP}")
    p.add_argument("--model", default=None,
                   help="H1-2 MJCF (default: the project's model), e.g. the manufacturer's "
                        "h1_2_handless.xml from unitree_ros")
    p.add_argument("--rotor-inertia", action="store_true",
                   help="give the joints the project's rotor inertia (armature), for a "
                        "model file without it such as the manufacturer's")
    p.add_argument("--pose", default="standing", choices=POSES)
    p.add_argument("--seconds", type=positive, default=10.0)
    p.add_argument("--push", type=bounded(0.0, MAX_PUSH_FORCE, "N"), default=0.0,
                   help=f"torso push force [N], at most {MAX_PUSH_FORCE:g}")
    p.add_argument("--push-angle", type=finite, default=0.0,
                   help="push direction in the world x-y plane [deg], 0 = +x")
    p.add_argument("--push-time", type=non_negative, default=2.0, help="[s]")
    p.add_argument("--push-duration", type=positive, default=0.2, help="[s]")
    p.add_argument("--delay-ms", type=bounded(0.0, MAX_DELAY_MS, "ms"), default=0.0,
                   help=f"actuation delay [ms], at most {MAX_DELAY_MS:g}")
    p.add_argument("--startup", action="store_true",
                   help="zero torque → interpolate → hold before the policy, as on hardware")
    p.add_argument("--no-video", action="store_true")
    p.add_argument("--force", action="store_true",
                   help="overwrite an earlier run's files in --out")
    p.add_argument("--fps", type=integer(1), default=25)
    p.add_argument("--out", default="sim2sim_out", help="output directory")


_sim2sim.configure = _configure  # type: ignore[attr-defined]
command("sim2sim", "Run an exported policy in MuJoCo (1 kHz physics, 50 Hz control) with "
        "a video and a balance trace.")(_sim2sim)
