"""``hybrid-recovery``: one entry point, thin subcommands over importable functions."""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
from collections.abc import Sequence

from hybrid_recovery.cli.errors import EXIT_ERROR, report_errors
from hybrid_recovery.cli.registry import COMMANDS, command, parse_overrides

__all__ = ["COMMANDS", "command", "main", "parse_overrides"]

_DEBUG_HELP = "print the traceback of an error (default: one line, 'error: ...')"


class _Parser(argparse.ArgumentParser):
    """argparse with the CLI's one error format: ``error: <message>``, exit 2."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_ERROR, f"error: {message}\n")


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
``bench train`` at load 11 measured the PPO update at 51.0 s per iteration with 2 spinning
threads, 12.6 s with PASSIVE (see ``training/README.md``, training throughput). libgomp
reads the variable once, when torch loads, so it is set before any subcommand runs."""


def _set_openmp_wait_policy() -> None:
    os.environ.setdefault("OMP_WAIT_POLICY", OMP_WAIT_POLICY)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs one subcommand; returns 0, 1 (a controller fault), 2 (an error, one line
    ``error: <message>`` on stderr) or 130 (Ctrl-C)."""
    _set_openmp_wait_policy()
    _register_all()

    parser = _Parser(prog="hybrid-recovery", description=__doc__)
    parser.add_argument("--debug", action="store_true", help=_DEBUG_HELP)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (help_text, fn) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help=_DEBUG_HELP)
        fn.configure(p)  # type: ignore[attr-defined]
        p.set_defaults(_run=fn)
    args = parser.parse_args(argv)
    return report_errors(lambda: int(args._run(args) or 0), args.debug)


if __name__ == "__main__":
    sys.exit(main())
