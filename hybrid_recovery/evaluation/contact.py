"""Contact-setting presets for sim-to-sim tests (``--contact``)."""

from __future__ import annotations

import mujoco

CONTACT_PRESETS: dict[str, dict[str, float]] = {
    "default": {},
    "slippery": {"friction": 0.4},
    "grippy": {"friction": 1.5},
    "soft": {"timeconst": 0.05},
    "stiff": {"timeconst": 0.01},
    "bouncy": {"dampratio": 0.5},
}
"""Preset → overrides of every geom's sliding friction μ, contact time constant [s] and
damping ratio (MuJoCo ``solref``)."""


def check_contact_preset(name: str) -> None:
    """Refuses an unknown preset name.

    Raises:
        ValueError: ``unknown contact preset '<name>': choose one of [...]``.
    """
    if name not in CONTACT_PRESETS:
        raise ValueError(f"unknown contact preset '{name}': choose one of {list(CONTACT_PRESETS)}")


def apply_contact_preset(model: mujoco.MjModel, name: str) -> None:
    """Writes the preset into ``model`` in place.

    Raises:
        ValueError: unknown preset name.
    """
    check_contact_preset(name)
    preset = CONTACT_PRESETS[name]
    if "friction" in preset:
        model.geom_friction[:, 0] = preset["friction"]
    if "timeconst" in preset:
        model.geom_solref[:, 0] = preset["timeconst"]
    if "dampratio" in preset:
        model.geom_solref[:, 1] = preset["dampratio"]
