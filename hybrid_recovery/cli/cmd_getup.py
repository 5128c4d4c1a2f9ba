"""``hybrid-recovery getup record``, ``getup map`` and ``getup margins``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import bounded, integer, positive
from hybrid_recovery.files import atomic_write_text, refuse_existing


def _getup(args: argparse.Namespace) -> int:
    return int(args._getup(args) or 0)


def _record(args: argparse.Namespace) -> int:
    from hybrid_recovery.evaluation.getup_record import record_rises

    out = record_rises(args.pose, args.episodes, args.out, duration=args.duration,
                       seed=args.seed, policy=args.policy, controller=args.controller,
                       force=args.force)
    print(f"kept {out['kept']} of {out['attempted']} rises: {out['path']}")
    return 0


def _map(args: argparse.Namespace) -> int:
    from hybrid_recovery.evaluation.handover_map import handover_map, map_table

    if args.out:
        refuse_existing(args.out, args.force)
    rows = handover_map(tuple(args.states), trials=args.trials, noise=args.noise,
                        duration=args.duration, seed=args.seed, policy=args.policy)
    table = map_table(rows)
    print(table)
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json.dumps(rows, indent=1) + "\n", out)
        print(f"rows: {out}")
    return 0


def _margins(args: argparse.Namespace) -> int:
    from hybrid_recovery.evaluation.move_margins import (
        margin_table,
        move_margins,
        plot_margins,
        write_csv,
    )

    for out in (args.out, args.plot):
        if out:
            refuse_existing(out, args.force)
    results = move_margins(None if args.move is None else [args.move], seeds=args.seed)
    print(margin_table(results))
    if args.out:
        print(f"states: {write_csv(results, args.out)}")
    if args.plot:
        print(f"plot: {plot_margins(results, args.plot)}")
    return 0


def _configure(p: argparse.ArgumentParser) -> None:
    from hybrid_recovery.evaluation.getup_record import RECORDERS
    from hybrid_recovery.evaluation.handover_map import HANDOVER_STATES
    from hybrid_recovery.evaluation.scenario import MAX_NOISE
    from hybrid_recovery.sim.initial_states import POSES

    sub = p.add_subparsers(dest="getup_command", required=True)
    rec = sub.add_parser("record", help="record successful rises (npz) of the hybrid or "
                         "of the model-based half")
    rec.add_argument("--pose", required=True, choices=POSES, help="start pose")
    rec.add_argument("--episodes", type=integer(1), required=True, help="episodes to run")
    rec.add_argument("--controller", choices=RECORDERS, default="hybrid",
                     help="hybrid: the ground moves, then --policy; model: the model-based "
                          "half alone (no policy)")
    rec.add_argument("--policy", default=None,
                     help="the hybrid's policy after the hand-over: an exported policy "
                          "(directory or policy.onnx), a training run directory (its newest "
                          "checkpoint), or 'shipped'")
    rec.add_argument("--out", required=True, help=".npz file to write (.npz is added to "
                     "another suffix)")
    rec.add_argument("--force", action="store_true", help="replace an existing --out")
    rec.add_argument("--duration", type=positive, default=30.0, help="trial length [s]")
    rec.add_argument("--seed", type=integer(0), default=0, help="seed of the first episode")
    rec.set_defaults(_getup=_record)
    hmap = sub.add_parser("map", help="the policy's success from each hand-over state")
    hmap.add_argument("--states", nargs="+", default=list(HANDOVER_STATES),
                      choices=list(HANDOVER_STATES))
    hmap.add_argument("--trials", type=integer(1), default=20, help="trials per state")
    hmap.add_argument("--noise", type=bounded(0.0, MAX_NOISE), default=1.0,
                      help="scale of the paper's initialisation noise")
    hmap.add_argument("--duration", type=positive, default=15.0, help="trial length [s]")
    hmap.add_argument("--seed", type=integer(0), default=0)
    hmap.add_argument("--policy", default="shipped", help="policy.onnx or its directory")
    hmap.add_argument("--out", default=None, help="JSON file for the rows")
    hmap.add_argument("--force", action="store_true", help="replace an existing --out")
    hmap.set_defaults(_getup=_map)
    marg = sub.add_parser("margins", help="the static margin table along each move")
    marg.add_argument("--move", default=None, help="one move (default: every move)")
    marg.add_argument("--seed", type=integer(0), nargs="+", default=[0],
                      help="seeds of the noisy starts (the table pools them)")
    marg.add_argument("--out", default=None, help="CSV file for every checked state")
    marg.add_argument("--plot", default=None, help="PNG: margin against time per move")
    marg.add_argument("--force", action="store_true", help="replace an existing --out or --plot")
    marg.set_defaults(_getup=_margins)


_getup.configure = _configure  # type: ignore[attr-defined]
command("getup", "Getting up: record hybrid rises, map the policy's hand-over states, "
        "check static margins along the moves.")(_getup)
