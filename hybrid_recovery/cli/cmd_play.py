"""``hybrid-recovery play``: one episode rendered to an MP4 with the balance overlay."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.errors import UsageError
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
    terrain,
)
from hybrid_recovery.evaluation.scenario import MAX_PUSH_FORCE


def _play(args: argparse.Namespace) -> int:
    from hybrid_recovery.files import refuse_existing

    check_push_time(args.push, args.push_time, args.seconds)
    refuse_existing(args.out, args.force)
    if args.terrain != "flat" and args.controller is None:  # a trial of the policy on it
        if args.randomize:
            raise UsageError("play: --randomize does not apply with --terrain (the take is an "
                             "evaluation trial, nominal physics)")
        args.controller = {"shipped": "learned", "zero": "zero"}.get(args.policy,
                                                                     f"onnx:{args.policy}")
    if args.controller is not None:
        return _play_controller(args)
    from hybrid_recovery.evaluation.play import onnx_policy, play
    from hybrid_recovery.policy import resolve_policy
    from hybrid_recovery.sim.render import renderer_backend

    check_model(args.model)
    policy = None if args.policy in (None, "zero") else onnx_policy(resolve_policy(args.policy))
    frames = play(args.out, pose=args.pose, seconds=args.seconds, policy=policy,
                  push=args.push, push_angle=args.push_angle, push_time=args.push_time,
                  push_duration=args.push_duration, fps=args.fps, seed=args.seed,
                  randomize=args.randomize, model_path=args.model)
    print(f"wrote {args.out} ({frames} frames at {args.fps} fps)")
    print(f"renderer: {renderer_backend()}")
    return 0


def _play_controller(args: argparse.Namespace) -> int:
    """An evaluation trial of ``--controller`` rendered (the runner's physics and start)."""
    import math

    from hybrid_recovery.controllers import make
    from hybrid_recovery.evaluation.scenario import Scenario
    from hybrid_recovery.evaluation.video import render_trial

    check_model(args.model)
    scenario = Scenario(args.pose, force=args.push, direction=math.radians(args.push_angle),
                        push_time=args.push_time, push_duration=args.push_duration,
                        duration=args.seconds, seed=args.seed, terrain=args.terrain)
    path = render_trial(make(args.controller), scenario, args.out, fps=args.fps,
                        model_path=args.model)
    print(f"wrote {path} ({args.controller}, {args.pose}, {args.seconds:g} s)")
    return 0


def _configure_play(p: argparse.ArgumentParser) -> None:
    from hybrid_recovery.sim.initial_states import POSES

    p.add_argument("--policy", default="shipped",
                   help="policy.onnx (or its export directory); 'shipped' for the shipped "
                        "policy; 'zero' for zero actions")
    p.add_argument("--controller", default=None,
                   help=f"render an evaluation trial of this controller instead: "
                        f"{CONTROLLER_HELP}")
    p.add_argument("--pose", default="standing", choices=POSES, help="start pose")
    p.add_argument("--seconds", type=positive, default=5.0, help="episode length [s]")
    p.add_argument("--out", default="play.mp4", help="video file to write")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.add_argument("--push", type=bounded(0.0, MAX_PUSH_FORCE, "N"), default=0.0, metavar="N",
                   help=f"torso push force [N] at --push-time (0: no push), at most "
                        f"{MAX_PUSH_FORCE:g}")
    p.add_argument("--push-time", type=non_negative, default=1.0, help="[s]")
    p.add_argument("--push-duration", type=positive, default=0.1, help="[s]")
    p.add_argument("--push-angle", type=finite, default=0.0,
                   help="push direction in the robot's heading frame [deg]: 0 forward, 90 left")
    p.add_argument("--fps", type=int, default=25, choices=(25, 50))
    p.add_argument("--seed", type=integer(0), default=0)
    p.add_argument("--randomize", action="store_true",
                   help="domain-randomised physics instead of nominal")
    p.add_argument("--model", default=None, help="robot MJCF (default: the project's H1-2)")
    p.add_argument("--terrain", type=terrain, default="flat",
                   help="the ground: flat, slope:DEG[:HEADING], rough:CM or step:CM (a "
                        "trial of --controller, or of --policy, on it)")


_play.configure = _configure_play  # type: ignore[attr-defined]
command("play", "Render one episode (a policy, or any --controller) to an MP4.")(_play)
