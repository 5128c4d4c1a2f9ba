"""``hybrid-recovery``: one entry point, thin subcommands over importable functions."""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
from collections.abc import Sequence

from hybrid_recovery.cli.registry import COMMANDS, command, parse_overrides

__all__ = ["COMMANDS", "command", "main", "parse_overrides"]


def _register_all() -> None:
    """Imports every ``hybrid_recovery.cli.cmd_*`` module; each registers its subcommand."""
    import hybrid_recovery.cli as package

    for info in pkgutil.iter_modules(package.__path__):
        if info.name.startswith("cmd_"):
            importlib.import_module(f"hybrid_recovery.cli.{info.name}")


OMP_WAIT_POLICY = "PASSIVE"
"""The OpenMP wait policy the CLI gives torch unless ``OMP_WAIT_POLICY`` is already set.

torch's OpenMP threads (libgomp) otherwise spin at every barrier, which on a shared
2-core machine takes the cores from the physics threads and the other processes:
``bench train`` at load 11 measured the PPO update at 27.8 s per iteration with 2 spinning
threads, 4.7 s with PASSIVE (see ``training/README.md``, training throughput). libgomp
reads the variable once, when torch loads, so it is set before any subcommand runs."""


def _set_openmp_wait_policy() -> None:
    os.environ.setdefault("OMP_WAIT_POLICY", OMP_WAIT_POLICY)


def main(argv: Sequence[str] | None = None) -> int:
    _set_openmp_wait_policy()
    _register_all()

    parser = argparse.ArgumentParser(prog="hybrid-recovery", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (help_text, fn) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        fn.configure(p)  # type: ignore[attr-defined]
        p.set_defaults(_run=fn)
    args = parser.parse_args(argv)
    result = args._run(args)
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
