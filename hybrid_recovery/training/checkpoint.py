"""Checkpoints: atomic writes and validated loads."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import torch

from hybrid_recovery.policy.description import check_meta

LATEST = "latest.pt"
"""File name of the newest checkpoint in a run directory."""


def atomic_save(obj: Any, path: str | Path) -> None:
    """torch.save to a temporary file in the same directory, fsync, then rename.

    A crash at any point leaves either the old file or the new one, never a partial one.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            torch.save(obj, handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_checkpoint(path: str | Path) -> dict:
    """Loads and validates a checkpoint written by :class:`RecoveryRunner`.

    Raises:
        FileNotFoundError: the file does not exist.
        ValueError: the file is corrupt, was not written by this project, or was trained
            for another robot or observation layout.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint not found: {path}")
    try:
        data = torch.load(path, weights_only=False, map_location="cpu")
    except Exception as err:  # torch raises several types for a damaged file
        raise ValueError(f"checkpoint {path} is corrupt or not a torch checkpoint: {err}") from err
    meta = (data.get("infos") or {}).get("meta") if isinstance(data, dict) else None
    if meta is None:
        raise ValueError(f"checkpoint {path} was not written by hybrid_recovery (no infos.meta)")
    check_meta(meta, str(path))
    return data
