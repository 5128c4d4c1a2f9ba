"""Options removed from the environment, and loading configs saved before their removal.

Each removed option was measured not to help (docs/experiments.md). A config saved
earlier, e.g. a run's ``config.json`` or a shipped policy's training record, still loads
when every removed key holds its neutral value, the value at which it did nothing.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from hybrid_recovery.envs.config import EnvConfig, apply_overrides

ANY_VALUE = object()
"""A removed key that did nothing whatever its value (it only took effect with another
removed key away from its neutral value)."""

REMOVED: dict[str, Any] = {
    "rewards.rise_vel_max": math.inf,
    "rewards.w_shin": 0.0,
    "assist.mode": "pull",
    "assist.stuck_time": None,
    "bridge.mix": 0.0,
    "bridge.stuck_time": None,
    "replay.fraction": 0.0,
    "replay.poses": ANY_VALUE,
    "replay.interval_s": ANY_VALUE,
    "replay.capacity": ANY_VALUE,
}
"""EnvConfig keys removed, with the neutral value at which each did nothing: start-state
replay, the ``gravity`` mode of the assistance, the assisted and bridged episodes' own
stuck-low windows, the rise-speed cap, the shin reward and the bridges' mixing of lower
levels. Configs saved before the
removal load when these keys hold their neutral values (the keys are dropped) and are
refused otherwise (:func:`drop_removed`)."""


def drop_removed(overrides: dict[str, Any]) -> dict[str, Any]:
    """Dotted EnvConfig overrides without the :data:`REMOVED` keys at their neutral values.

    Raises:
        ValueError: a removed key set to any other value, naming it and its neutral value.
    """
    kept = {}
    for key, value in overrides.items():
        if key not in REMOVED:
            kept[key] = value
            continue
        neutral = REMOVED[key]
        if neutral is not ANY_VALUE and value != neutral:
            raise ValueError(f"'{key}' was removed from the environment; this config sets it "
                             f"to {value!r}, and only its neutral value {neutral!r} can load "
                             "(docs/experiments.md says what it did)")
    return kept


def env_config_from_dict(data: dict[str, Any]) -> EnvConfig:
    """The EnvConfig saved as a dict (``dataclasses.asdict``, as in a run's ``config.json``
    or a training record), older ones included (:data:`REMOVED`).

    Raises:
        ValueError: a removed option set away from its neutral value.
        KeyError: any other unknown key.
    """
    return apply_overrides(EnvConfig(), drop_removed(_dotted(EnvConfig(), data)))


def _dotted(cfg: Any, data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested dict → dotted keys, descending into nested config sections (and removed
    sections), not into dict-valued fields such as ``pose_weights``."""
    out: dict[str, Any] = {}
    names = {f.name for f in dataclasses.fields(cfg)}
    for key, value in data.items():
        dotted = prefix + key
        section = getattr(cfg, key) if key in names else None
        if dataclasses.is_dataclass(section) and isinstance(value, dict):
            out.update(_dotted(section, value, dotted + "."))
        elif key not in names and isinstance(value, dict) and any(
                r.startswith(dotted + ".") for r in REMOVED):
            out.update({f"{dotted}.{k}": v for k, v in value.items()})
        else:
            out[dotted] = value
    return out
