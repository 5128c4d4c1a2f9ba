"""``hybrid-recovery bench``."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.errors import UsageError
from hybrid_recovery.cli.registry import command, parse_overrides
from hybrid_recovery.cli.validate import integer


def _bench(args: argparse.Namespace) -> int:
    from hybrid_recovery.bench import BENCHES

    options = {"n": args.n, "repeat": args.repeat, "seed": args.seed}
    if args.set:
        if args.what != "env":
            raise UsageError("--set applies to 'bench env' only")
        options["overrides"] = parse_overrides(args.set)
    result = BENCHES[args.what](**{k: v for k, v in options.items() if v is not None})
    print(result.table())
    print(result.json_line())
    return 0


def _configure_bench(p: argparse.ArgumentParser) -> None:
    from hybrid_recovery.bench import BENCHES

    p.add_argument("what", choices=sorted(BENCHES), help="what to time")
    p.add_argument("-n", type=integer(1), default=None,
                   help="problem size, e.g. number of states (default: the bench's own)")
    p.add_argument("--repeat", type=integer(1), default=None, help="timed runs, the best is kept")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="EnvConfig overrides for 'bench env', e.g. physics_dt=0.01 decimation=2")


_bench.configure = _configure_bench  # type: ignore[attr-defined]
command("bench", "Time a layer: µs per state and ratios; the last line is JSON.")(_bench)
