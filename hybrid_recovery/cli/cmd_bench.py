"""``hybrid-recovery bench``."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.registry import command, parse_overrides


def _bench(args: argparse.Namespace) -> int:
    from hybrid_recovery.bench import BENCHES

    options = {"n": args.n, "repeat": args.repeat, "seed": args.seed}
    if args.set:
        if args.what not in ("env", "train"):
            raise SystemExit("--set applies to 'bench env' and 'bench train' only")
        options["overrides"] = parse_overrides(args.set)
    result = BENCHES[args.what](**{k: v for k, v in options.items() if v is not None})
    print(result.table())
    print(result.json_line())
    return 0


def _configure_bench(p: argparse.ArgumentParser) -> None:
    from hybrid_recovery.bench import BENCHES

    p.add_argument("what", choices=sorted(BENCHES), help="what to time")
    p.add_argument("-n", type=int, default=None,
                   help="problem size, e.g. number of states (default: the bench's own)")
    p.add_argument("--repeat", type=int, default=None, help="timed runs, the best is kept")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="'bench env': EnvConfig overrides, e.g. physics_dt=0.01 decimation=2; "
                        "'bench train': TrainConfig settings, e.g. torch_threads=1 "
                        "ppo.mixed_precision=true ppo.num_mini_batches=2")


_bench.configure = _configure_bench  # type: ignore[attr-defined]
command("bench", "Time a layer: µs per state and ratios; the last line is JSON.")(_bench)
