"""Training variants: the paper's full and reduced policies and single-factor ablations."""

from __future__ import annotations

from typing import Any

VARIANTS: dict[str, dict[str, Any]] = {
    "full": {},
    # the paper's ablation: all three removed together
    "reduced": {"privileged_critic": False, "rewards.use_capture_point": False,
                "curriculum.enabled": False},
    # single-factor ablations (beyond the paper)
    "no_privileged": {"privileged_critic": False},
    "no_capture_point": {"rewards.use_capture_point": False},
    "no_curriculum": {"curriculum.enabled": False},
}
"""Variant name → EnvConfig overrides."""


def variant_overrides(name: str) -> dict[str, Any]:
    """The EnvConfig overrides of variant ``name``.

    Raises:
        KeyError: naming the unknown variant and the known ones.
    """
    if name not in VARIANTS:
        raise KeyError(f"unknown variant '{name}': choose one of {sorted(VARIANTS)}")
    return dict(VARIANTS[name])
