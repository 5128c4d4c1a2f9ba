"""``hybrid-recovery``: one entry point, thin subcommands over importable functions."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence

_COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None]]] = {}


def command(name: str, help_text: str):
    """Registers ``fn(args)`` as subcommand ``name``; ``fn.configure(parser)`` adds options."""

    def wrap(fn):
        _COMMANDS[name] = (help_text, fn)
        return fn

    return wrap


def _parse_overrides(items: Sequence[str]) -> dict:
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


def main(argv: Sequence[str] | None = None) -> int:
    from hybrid_recovery.cli import commands  # noqa: F401  (registers the subcommands)

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
