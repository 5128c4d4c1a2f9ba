"""Checks of command-line values at the edge, before any work is done or any file written.

The number checks are argparse ``type=`` functions: a refused value ends the command
with ``error: argument --trials: must be an integer >= 1, got '-5'`` and exit 2.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

from hybrid_recovery.cli.errors import UsageError


def integer(minimum: int) -> Callable[[str], int]:
    """An argparse type: an integer ≥ ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {text!r}")
        return value

    return parse


def number(minimum: float, inclusive: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite number > ``minimum`` (≥ with ``inclusive``)."""
    relation = ">=" if inclusive else ">"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        ok = math.isfinite(value) and (value >= minimum if inclusive else value > minimum)
        if not ok:
            raise argparse.ArgumentTypeError(
                f"must be a finite number {relation} {minimum:g}, got {text!r}")
        return value

    return parse


def bounded(low: float, high: float, unit: str = "") -> Callable[[str], float]:
    """An argparse type: a finite number in [``low``, ``high``] (``unit`` for the message,
    e.g. ``must be a finite number from 0 to 1000 N, got '1e9'``)."""
    span = f"from {low:g} to {high:g}" + (f" {unit}" if unit else "")

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and low <= value <= high):
            raise argparse.ArgumentTypeError(f"must be a finite number {span}, got {text!r}")
        return value

    return parse


class Distinct(argparse.Action):
    """An argparse action for a list option (``nargs``): refuses a value given twice,
    ``argument --forces: duplicate value '300'`` (numbers compared by value)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values, option_string: str | None = None) -> None:
        seen = set()
        for value in values:
            if value in seen:
                text = f"{value:g}" if isinstance(value, float) else str(value)
                raise argparse.ArgumentError(self, f"duplicate value {text!r}")
            seen.add(value)
        setattr(namespace, self.dest, values)


def finite(text: str) -> float:
    """An argparse type: any finite number."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def check_push_time(force: float, push_time: float, seconds: float) -> None:
    """Refuses a push that starts when the run is over: it would never be applied.

    Raises:
        UsageError: ``argument --push-time: the push starts at 6 s, when the 5 s run is
            over (--seconds)``.
    """
    if force > 0 and push_time >= seconds:
        raise UsageError(f"argument --push-time: the push starts at {push_time:g} s, when "
                         f"the {seconds:g} s run is over (--seconds)")


def check_model(path: str | None) -> None:
    """Loads a ``--model`` MJCF once, so that a missing or malformed file is refused
    before any work, with its name in the message.

    Raises:
        FileNotFoundError: no such file.
        ValueError: MuJoCo cannot parse or compile it, or it is not an H1-2.
    """
    if path is None:
        return
    from hybrid_recovery.robot.mjcf import load_mjmodel

    load_mjmodel(Path(path))


non_negative = number(0.0, inclusive=True)
"""An argparse type: a finite number >= 0."""
positive = number(0.0)
"""An argparse type: a finite number > 0."""


def add_backend_options(p: argparse.ArgumentParser) -> None:
    """``--backend`` and ``--device``: where the physics (and the learner) run."""
    from hybrid_recovery.sim.backend import BACKENDS, DEVICES

    p.add_argument("--backend", choices=BACKENDS, default=None,
                   help="physics: batch (CPU MuJoCo, the default) | warp (MuJoCo Warp, the "
                        "'warp' extra)")
    p.add_argument("--device", choices=DEVICES, default=None,
                   help="cpu (the default) | cuda (with --backend warp; the learner too)")


CONTROLLER_HELP = ("zero | learned (the shipped policy) | onnx:PATH | qp | model | "
                   "hybrid[:PATH] (hybrid_recovery.controllers.CONTROLLERS)")
"""The ``--controller`` help of every command that takes one (tested against the
registry, which is not imported to build the parser)."""


def terrain(text: str) -> str:
    """An argparse type: a terrain (:func:`hybrid_recovery.sim.terrain.parse_terrain`), as
    its canonical text (``slope:10.0`` → ``slope:10``)."""
    from hybrid_recovery.sim.terrain import parse_terrain

    try:
        return parse_terrain(text).text
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
