"""The numbers of a dataclass config, checked at construction: finite and in range.

A config's ``__post_init__`` calls :func:`check_fields` with a table of ranges next to
the dataclass; a refused value raises ``ValueError`` naming the class and the field:
``FeasibilityConfig.floor_height must be finite, got nan``,
``ContactQpConfig.friction must be > 0, got 0.0``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import types
import typing
from collections.abc import Collection, Mapping
from typing import Any

Range = tuple[float, bool, float]
"""(low, low allowed, high): x is in range when x > low (x ≥ low when allowed) and
x ≤ high."""

FINITE: Range = (-math.inf, False, math.inf)
"""Any finite number."""
POSITIVE: Range = (0.0, False, math.inf)
"""x > 0."""
NON_NEGATIVE: Range = (0.0, True, math.inf)
"""x ≥ 0."""
UNIT: Range = (0.0, True, 1.0)
"""0 ≤ x ≤ 1."""


def bound_text(bounds: Range) -> str:
    """The range in words: ``> 0``, ``>= 1``, ``> 0 and <= 1``, ``<= 10``."""
    low, closed, high = bounds
    parts = [] if low == -math.inf else [f"{'>=' if closed else '>'} {low:g}"]
    if high != math.inf:
        parts.append(f"<= {high:g}")
    return " and ".join(parts)


def in_range(value: float, bounds: Range) -> bool:
    """Whether ``value`` lies in ``bounds`` (NaN never does)."""
    low, closed, high = bounds
    return (value >= low if closed else value > low) and value <= high


def check_fields(config: Any, ranges: Mapping[str, Range] | None = None,
                 infinite: Collection[str] = (), pairs: Collection[str] = ()) -> None:
    """Checks every number of a dataclass instance: the int and float fields and the
    numbers inside tuple, list and dict fields (nested dataclasses check themselves).

    Args:
        config: The dataclass instance.
        ranges: Field name → its range; unlisted fields may be any finite number.
        infinite: Fields where ±inf is allowed (a "no limit"); NaN never is.
        pairs: Fields that are (low, high) pairs, which must have low <= high.

    Raises:
        ValueError: ``<Class>.<field> must be a number, got '1'``, ``... must be an
            integer, got 1.5``, ``... must be finite, got nan``, ``... must be > 0,
            got -1.0``, ``... must be a (low, high) pair with low <= high, got
            (2.0, 1.0)``.
    """
    ranges = ranges or {}
    cls: Any = type(config)
    for name, hint in _number_fields(cls).items():
        label = f"{cls.__name__}.{name}"
        value = getattr(config, name)
        _check_value(label, value, hint, ranges.get(name), name in infinite)
        if name in pairs and value[0] > value[1]:
            raise ValueError(f"{label} must be a (low, high) pair with low <= high, "
                             f"got {_show(value)}")


@functools.cache
def _number_fields(cls: type) -> dict[str, Any]:
    """The fields of ``cls`` whose declared type holds numbers → that type."""
    hints = typing.get_type_hints(cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)
            if _holds_numbers(hints[f.name])}


def _holds_numbers(hint: Any) -> bool:
    if hint in (int, float):
        return True
    return any(_holds_numbers(a) for a in typing.get_args(hint) if a is not Ellipsis)


def _show(value: Any) -> str:
    if isinstance(value, tuple | list):
        inner = ", ".join(_show(v) for v in value)
        return f"({inner})" if isinstance(value, tuple) else f"[{inner}]"
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return repr(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return repr(float(value))
    return repr(value)


def _check_value(label: str, value: Any, hint: Any, bounds: Range | None,
                 infinite: bool) -> None:
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return
        inner = [a for a in args if a is not type(None)]
        hint = inner[0] if len(inner) == 1 else float
        origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (tuple, list) and isinstance(value, tuple | list):
        item_hints = (args if origin is tuple and Ellipsis not in args
                      else (args[0],) * len(value))
        for item, item_hint in zip(value, item_hints, strict=False):
            _check_value(label, item, item_hint, bounds, infinite)
        return
    if origin is dict and isinstance(value, dict):
        for item in value.values():
            _check_value(label, item, args[1], bounds, infinite)
        return
    if hint not in (int, float):
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{label} must be a number, got {_show(value)}")
    if hint is int and not isinstance(value, numbers.Integral):
        raise ValueError(f"{label} must be an integer, got {_show(value)}")
    x = float(value)
    if math.isnan(x) or (math.isinf(x) and not infinite):
        raise ValueError(f"{label} must be finite, got {_show(value)}")
    if bounds is not None and not in_range(x, bounds):
        raise ValueError(f"{label} must be {bound_text(bounds)}, got {_show(value)}")
