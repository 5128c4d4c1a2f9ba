"""``hybrid-recovery bench-deploy``."""

from __future__ import annotations

import argparse
import json

from hybrid_recovery.cli.registry import command
from hybrid_recovery.cli.validate import positive


def _bench_deploy(args: argparse.Namespace) -> int:
    from hybrid_recovery.deploy.bench import bench_deploy, format_bench

    result = bench_deploy(args.seconds, args.policy, realtime=not args.no_realtime,
                          domain_id=args.domain)
    print(format_bench(result))
    print(json.dumps({"bench": "deploy", **result}))
    return 0 if result["controller"]["fault"] is None else 1


def _configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seconds", type=positive, default=60.0, help="controller run time [s]")
    p.add_argument("--policy", default=None,
                   help="exported policy directory (default: a random stand-in of the same size)")
    p.add_argument("--no-realtime", action="store_true",
                   help="do not ask for SCHED_FIFO (normal scheduling)")
    p.add_argument("--domain", type=int, default=None, help="DDS domain id (default random)")


_bench_deploy.configure = _configure  # type: ignore[attr-defined]
command("bench-deploy", "ONNX inference latency and 50 Hz loop jitter over loopback DDS; "
        "the last line is JSON.")(_bench_deploy)
