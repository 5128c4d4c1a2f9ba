"""Checks of configuration values where they are declared: numbers finite and in range."""

from hybrid_recovery.checks.fields import (
    FINITE,
    NON_NEGATIVE,
    POSITIVE,
    UNIT,
    Range,
    bound_text,
    check_fields,
    in_range,
)

__all__ = ["FINITE", "NON_NEGATIVE", "POSITIVE", "UNIT", "Range", "bound_text",
           "check_fields", "in_range"]
