"""The subcommand registry: each ``cmd_<name>`` module registers itself here."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Sequence

from hybrid_recovery.cli.errors import UsageError

COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None]]] = {}


def command(name: str, help_text: str):
    """Registers ``fn(args)`` as subcommand ``name``; ``fn.configure(parser)`` adds options.

    Each subcommand lives in its own module ``hybrid_recovery/cli/cmd_<name>.py``.
    """

    def wrap(fn):
        COMMANDS[name] = (help_text, fn)
        return fn

    return wrap


def parse_overrides(items: Sequence[str]) -> dict:
    """``key=value`` pairs; values parsed as JSON when they can be (numbers, lists, true),
    else kept as strings. A value that opens a JSON list or object must be one: a bare
    ``[a, b]`` is refused rather than read as a string of characters."""
    out = {}
    for item in items:
        if "=" not in item:
            raise UsageError(f"override '{item}' must look like key=value, e.g. rewards.w_cp=0")
        key, raw = item.split("=", 1)
        try:
            out[key] = json.loads(raw)
        except json.JSONDecodeError as err:
            if raw.lstrip()[:1] in ("[", "{"):
                raise UsageError(f"override '{item}': the value is not valid JSON ({err.msg}); "
                                 "quote strings in lists, e.g. "
                                 "assist.poses='[\"supine\", \"prone\"]'") from None
            out[key] = raw
    return out
