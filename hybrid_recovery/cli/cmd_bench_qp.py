"""``hybrid-recovery bench-qp``: QP solve times and the standing push-recovery sweep."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.main import command


def _bench_qp(args: argparse.Namespace) -> int:
    from hybrid_recovery.bench.qp import push_sweep, solve_timing, sweep_table

    if args.what in ("timing", "all"):
        solve_timing(push_force=args.timing_push, duration=args.timing_duration)
    if args.what in ("sweep", "all"):
        start, stop, step = (float(x) for x in args.forces.split(":"))
        forces = [start + i * step for i in range(int(round((stop - start) / step)) + 1)]
        stepping = {"off": (False,), "on": (True,), "both": (False, True)}[args.stepping]
        rows = push_sweep(forces, args.directions.split(","), stepping, results=args.results)
        print(sweep_table(rows))
    return 0


def _configure_bench_qp(p: argparse.ArgumentParser) -> None:
    p.add_argument("what", nargs="?", default="all", choices=("timing", "sweep", "all"))
    p.add_argument("--timing-push", type=float, default=300.0, help="push of the timed run [N]")
    p.add_argument("--timing-duration", type=float, default=2.0, help="timed run [s]")
    p.add_argument("--forces", default="0:500:50", help="start:stop:step [N]")
    p.add_argument("--directions", default="+x,-x,+y,-y")
    p.add_argument("--stepping", default="both", choices=("off", "on", "both"))
    p.add_argument("--results", default=None,
                   help="JSON-lines file: rows are appended and reused (resumable sweep)")


_bench_qp.configure = _configure_bench_qp  # type: ignore[attr-defined]
command("bench-qp", "QP balance baseline: solve time per tick and the push-recovery sweep.")(
    _bench_qp)
