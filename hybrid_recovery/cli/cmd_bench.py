"""``hybrid-recovery bench {dynamics,env,terms,train,qp,deploy}``: one command, one target
each."""

from __future__ import annotations

import argparse
import json
import math

from hybrid_recovery.cli.registry import command, parse_overrides
from hybrid_recovery.cli.validate import add_backend_options, bounded, integer, positive
from hybrid_recovery.evaluation.scenario import MAX_PUSH_FORCE

LAYER_BENCHES = ("dynamics", "env", "terms", "train")
"""Targets of :data:`hybrid_recovery.bench.BENCHES`: a table, then one JSON line."""


def _bench(args: argparse.Namespace) -> int:
    if args.what == "qp":
        return _bench_qp(args)
    if args.what == "deploy":
        return _bench_deploy(args)
    from hybrid_recovery.bench import BENCHES

    options = {"n": args.n, "repeat": args.repeat, "seed": args.seed,
               "backend": getattr(args, "backend", None), "device": getattr(args, "device", None)}
    if getattr(args, "set", None):
        options["overrides"] = parse_overrides(args.set)
    result = BENCHES[args.what](**{k: v for k, v in options.items() if v is not None})
    print(result.table())
    print(result.json_line())
    return 0


def _bench_qp(args: argparse.Namespace) -> int:
    from hybrid_recovery.bench.qp import push_sweep, solve_timing, sweep_table

    if args.mode in ("timing", "all"):
        solve_timing(push_force=args.timing_push, duration=args.timing_duration)
    if args.mode in ("sweep", "all"):
        stepping = {"off": (False,), "on": (True,), "both": (False, True)}[args.stepping]
        rows = push_sweep(args.forces, args.directions, stepping, results=args.results)
        print(sweep_table(rows))
    return 0


def _bench_deploy(args: argparse.Namespace) -> int:
    from hybrid_recovery.bench.deploy import bench_deploy, format_bench

    result = bench_deploy(args.seconds, args.policy, realtime=not args.no_realtime,
                          domain_id=args.domain)
    print(format_bench(result))
    print(json.dumps({"bench": "deploy", **result}))
    return 0 if result["controller"]["fault"] is None else 1


def _force_grid(text: str) -> list[float]:
    """An argparse type: ``start:stop:step`` [N] → the forces start, start + step, …, stop,
    with 0 <= start <= stop <= ``MAX_PUSH_FORCE`` and step > 0 (step ignored when start =
    stop)."""
    try:
        start, stop, step = (float(x) for x in text.split(":"))
    except ValueError:
        start = stop = step = math.nan
    ok = (all(math.isfinite(v) for v in (start, stop, step))
          and 0.0 <= start <= stop <= MAX_PUSH_FORCE and (step > 0.0 or start == stop))
    if not ok:
        raise argparse.ArgumentTypeError(
            f"must be start:stop:step [N] with 0 <= start <= stop <= {MAX_PUSH_FORCE:g} and "
            f"step > 0, got {text!r}")
    count = 1 if start == stop else int(math.floor((stop - start) / step + 1e-9)) + 1
    return [start + i * step for i in range(count)]


def _directions(text: str) -> list[str]:
    """An argparse type: comma-separated push directions of ``bench.qp.DIRECTIONS``, each
    once."""
    from hybrid_recovery.bench.qp import DIRECTIONS

    names = tuple(DIRECTIONS)
    picked = text.split(",")
    for name in picked:
        if name not in names:
            raise argparse.ArgumentTypeError(
                f"unknown direction {name!r}: choose from {','.join(names)}, got {text!r}")
    for name in picked:
        if picked.count(name) > 1:
            raise argparse.ArgumentTypeError(f"duplicate value {name!r}")
    return picked


def _configure_bench(p: argparse.ArgumentParser) -> None:
    targets = p.add_subparsers(dest="what", required=True, metavar="{" + ",".join(
        (*LAYER_BENCHES, "qp", "deploy")) + "}")
    helps = {"dynamics": "balance quantities per state against mj_forward",
             "env": "environment steps per second and their split",
             "terms": "the MDP's per-step terms on numpy and on torch tensors (CPU or GPU)",
             "train": "end-to-end training throughput against the physics-only rate, and "
                      "the PPO update's parts"}
    for name in LAYER_BENCHES:
        t = targets.add_parser(name, help=helps[name], description=helps[name])
        t.add_argument("-n", type=integer(1), default=None,
                       help="problem size, e.g. number of states (default: the bench's own)")
        t.add_argument("--repeat", type=integer(1), default=None,
                       help="timed runs, the best is kept")
        t.add_argument("--seed", type=integer(0), default=None)
        if name in ("env", "train"):
            add_backend_options(t)
        if name == "terms":
            t.add_argument("--device", choices=("cpu", "cuda"), default=None,
                           help="where the torch tensors live (default cpu)")
        if name == "env":
            t.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                           help="EnvConfig overrides, e.g. physics_dt=0.01 decimation=2")
        if name == "train":
            t.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                           help="TrainConfig settings, e.g. torch_threads=1 "
                                "ppo.mixed_precision=true ppo.num_mini_batches=2")
    qp = targets.add_parser("qp", help="QP balance baseline: solve time per tick and the "
                            "push-recovery sweep")
    qp.add_argument("mode", nargs="?", default="all", choices=("timing", "sweep", "all"))
    qp.add_argument("--timing-push", type=bounded(0.0, MAX_PUSH_FORCE, "N"), default=300.0,
                    help=f"push of the timed run [N], at most {MAX_PUSH_FORCE:g}")
    qp.add_argument("--timing-duration", type=positive, default=2.0, help="timed run [s]")
    qp.add_argument("--forces", type=_force_grid, default="0:500:50",
                    help=f"start:stop:step [N], 0 to {MAX_PUSH_FORCE:g}")
    qp.add_argument("--directions", type=_directions, default="+x,-x,+y,-y",
                    help="comma-separated, of +x,-x,+y,-y")
    qp.add_argument("--stepping", default="both", choices=("off", "on", "both"))
    qp.add_argument("--results", default=None,
                    help="JSON-lines file: rows are appended and reused (resumable sweep)")
    dep = targets.add_parser("deploy", help="ONNX inference latency and 50 Hz loop jitter "
                             "over loopback DDS")
    dep.add_argument("--seconds", type=positive, default=60.0, help="controller run time [s]")
    dep.add_argument("--policy", default=None, help="exported policy directory (default: a "
                     "random stand-in of the same size)")
    dep.add_argument("--no-realtime", action="store_true",
                     help="do not ask for SCHED_FIFO (normal scheduling)")
    dep.add_argument("--domain", type=int, default=None, help="DDS domain id (default random)")


_bench.configure = _configure_bench  # type: ignore[attr-defined]
command("bench", "Time a layer (dynamics, env, terms, train, qp, deploy); the last line is "
        "JSON.")(
    _bench)
