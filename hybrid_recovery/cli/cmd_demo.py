"""``hybrid-recovery demo``."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.registry import command


def _demo(args: argparse.Namespace) -> int:
    from hybrid_recovery.demo.balance_report import balance_report, print_report

    print_report(balance_report(push_force=args.push), args.push)
    return 0


def _configure_demo(p: argparse.ArgumentParser) -> None:
    p.add_argument("--push", type=float, default=150.0, help="torso push force [N]")


_demo.configure = _configure_demo  # type: ignore[attr-defined]
command("demo", "The main job: a balance report of the H1-2 under a torso push.")(_demo)
