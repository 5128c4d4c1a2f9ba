"""``hybrid-recovery``: one entry point, thin subcommands over importable functions."""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import sys
from collections.abc import Callable, Sequence

_COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None]]] = {}


def command(name: str, help_text: str):
    """Registers ``fn(args)`` as subcommand ``name``; ``fn.configure(parser)`` adds options.

    Each subcommand lives in its own module ``hybrid_recovery/cli/cmd_<name>.py``.
    """

    def wrap(fn):
        _COMMANDS[name] = (help_text, fn)
        return fn

    return wrap


def parse_overrides(items: Sequence[str]) -> dict:
    """``key=value`` pairs; values parsed as JSON when they can be (numbers, lists, true)."""
    out = {}
    for item in items:
        if "=" not in item:
            raise SystemExit(f"override '{item}' must look like key=value, e.g. rewards.w_cp=0")
        key, raw = item.split("=", 1)
        try:
            out[key] = json.loads(raw)
        except json.JSONDecodeError:
            out[key] = raw
    return out


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
    for name, (help_text, fn) in _COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        fn.configure(p)  # type: ignore[attr-defined]
        p.set_defaults(_run=fn)
    args = parser.parse_args(argv)
    result = args._run(args)
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
