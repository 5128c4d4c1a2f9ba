"""``hybrid-recovery``: one entry point, thin subcommands over importable functions."""

from __future__ import annotations

import argparse
import importlib
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


def main(argv: Sequence[str] | None = None) -> int:
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
