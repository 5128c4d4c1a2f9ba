"""Where the shipped H1-2 recovery policy lives, and the name that selects it."""

from __future__ import annotations

from pathlib import Path

SHIPPED_POLICY = Path(__file__).resolve().parents[2] / "models" / "policies" / "h1_2_recovery"
"""Directory of the shipped policy: ``policy.onnx``, ``policy.json``, training record."""

SHIPPED = "shipped"
"""The policy argument (``--policy shipped``, ``onnx:shipped``) naming :data:`SHIPPED_POLICY`."""


def is_shipped() -> bool:
    """Whether a trained policy is shipped with this checkout."""
    return (SHIPPED_POLICY / "policy.onnx").is_file()


def resolve_policy(policy: str | Path) -> Path:
    """``policy`` as a path; ``"shipped"`` names :data:`SHIPPED_POLICY`.

    Raises:
        FileNotFoundError: ``"shipped"`` when no policy is shipped; ``policy directory
            not found: DIR`` (or ``ONNX policy not found: FILE.onnx``) for a path that
            does not exist.
    """
    if str(policy) != SHIPPED:
        path = Path(policy)
        if not path.exists():
            kind = "ONNX policy" if path.suffix == ".onnx" else "policy directory"
            raise FileNotFoundError(f"{kind} not found: {policy}")
        return path
    if not is_shipped():
        raise FileNotFoundError(
            f"no policy is shipped (no policy.onnx in {SHIPPED_POLICY}); train and export "
            "one: hybrid-recovery export RUN_DIR --out models/policies/h1_2_recovery")
    return SHIPPED_POLICY
