"""``hybrid-recovery demo``: the main job for a newcomer."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import CONTROLLER_HELP, Distinct, bounded
from hybrid_recovery.evaluation.scenario import MAX_PUSH_FORCE


def _demo(args: argparse.Namespace) -> int:
    if args.balance:
        from hybrid_recovery.demo.balance_report import balance_report, print_report

        print_report(balance_report(push_force=args.push), args.push)
        return 0
    from hybrid_recovery.demo.comparison import run_demo

    run_demo(args.out, video=not args.no_video, controllers=args.controller)
    return 0


def _configure_demo(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="results/demo", help="report and video directory")
    p.add_argument("--no-video", action="store_true")
    p.add_argument("--controller", nargs="+", default=None, action=Distinct,
                   help=f"only these controllers (default: every available one): "
                        f"{CONTROLLER_HELP}")
    p.add_argument("--balance", action="store_true",
                   help="only print the dynamics layer's balance report of a pushed robot")
    p.add_argument("--push", type=bounded(0.0, MAX_PUSH_FORCE, "N"), default=150.0,
                   help=f"--balance: push force [N], at most {MAX_PUSH_FORCE:g}")


_demo.configure = _configure_demo  # type: ignore[attr-defined]
command("demo", "The main job: controllers side by side on pushes, a fall and stand-ups.")(_demo)
