"""Checkpoints: atomic writes and validated loads."""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import torch

from hybrid_recovery.files import atomic_write, atomic_write_text
from hybrid_recovery.policy.description import check_meta

__all__ = ["LATEST", "RUN_CONFIG", "atomic_save", "atomic_write_text", "check_state_shapes",
           "grow_critic_inputs", "load_checkpoint", "load_latest", "numbered_checkpoints",
           "read_run_config"]

LATEST = "latest.pt"
"""File name of the newest checkpoint in a run directory."""
RUN_CONFIG = "config.json"
"""File name of a run's resolved settings (train and env configs, amendments)."""


def atomic_save(obj: Any, path: str | Path) -> None:
    """torch.save to a temporary file in the same directory, fsync, then rename.

    A crash at any point leaves either the old file or the new one, never a partial one.
    """
    atomic_write(path, "wb", lambda handle: torch.save(obj, handle))


def check_state_shapes(saved: Mapping[str, Any], model: Mapping[str, Any], part: str,
                       source: str | Path, variant: str | None = None) -> None:
    """Refuses a saved state dict that does not fit a model's, before ``load_state_dict``
    prints torch's many-line size mismatch.

    Args:
        saved: The checkpoint's state dict of one part (e.g. ``actor_state_dict``).
        model: The model's own ``state_dict()``.
        part: The part's name for the message (``actor``, ``critic``).
        source: The checkpoint file, for the message.
        variant: The checkpoint's training variant (``infos.meta.variant``), if known.

    Raises:
        ValueError: one line naming the file, the variant, the part and the first
            tensor whose shape differs (or that one side lacks), e.g. ``checkpoint
            runs/a/latest.pt (variant 'wide') does not fit this model's actor:
            mlp.0.weight is [512, 87] there, [256, 87] here (2 tensors differ)``.
    """
    problems = []
    for name in sorted(set(saved) | set(model)):
        if name not in model:
            problems.append(f"{name} is there, not here")
        elif name not in saved:
            problems.append(f"{name} is here, not there")
        else:
            there, here = _shape(saved[name]), _shape(model[name])
            if there != here:
                problems.append(f"{name} is {there} there, {here} here")
    if not problems:
        return
    of = f" (variant {variant!r})" if variant else ""
    more = f" ({len(problems)} tensors differ)" if len(problems) > 1 else ""
    raise ValueError(f"checkpoint {source}{of} does not fit this model's {part}: "
                     f"{problems[0]}{more}")


def grow_critic_inputs(data: dict, width: int, first_param: int) -> int:
    """Widens a checkpoint's critic, in place, to ``width`` inputs, appended after its own:
    their first-layer weights zero (the critic's values are unchanged), their normaliser
    mean 0 and variance 1, and their Adam moments zero. For a run amended to give the
    critic more privileged inputs (the terrain's heights, appended last).

    Args:
        data: a checkpoint (``critic_state_dict``, ``optimizer_state_dict``).
        width: the critic's new number of inputs.
        first_param: the index of the critic's first-layer weight in the optimiser's
            parameters (the actor's parameters come first).

    Returns:
        The number of inputs added (0 when the critic has ``width`` already).

    Raises:
        ValueError: the critic has more inputs than ``width``.
    """
    critic = data["critic_state_dict"]
    weight = critic["mlp.0.weight"]
    added = width - int(weight.shape[1])
    if added < 0:
        raise ValueError(f"the checkpoint's critic takes {weight.shape[1]} inputs, more than "
                         f"the {width} of this run")
    if added == 0:
        return 0
    critic["mlp.0.weight"] = torch.cat([weight, weight.new_zeros(weight.shape[0], added)], 1)
    for name, fill in (("_mean", 0.0), ("_var", 1.0), ("_std", 1.0)):
        key = f"obs_normalizer.{name}"
        if key in critic:
            critic[key] = torch.cat([critic[key], critic[key].new_full((1, added), fill)], 1)
    moments = data["optimizer_state_dict"]["state"].get(first_param, {})
    for key in ("exp_avg", "exp_avg_sq"):
        if key in moments:
            moments[key] = torch.cat([moments[key], moments[key].new_zeros(
                moments[key].shape[0], added)], 1)
    return added


def _shape(value: Any) -> list[int] | None:
    shape = getattr(value, "shape", None)
    return None if shape is None else [int(n) for n in shape]


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


def numbered_checkpoints(run_dir: str | Path) -> list[Path]:
    """The run's ``model_<it>.pt`` files, oldest iteration first."""
    found = [p for p in Path(run_dir).glob("model_*.pt") if p.stem[6:].isdigit()]
    return sorted(found, key=lambda p: int(p.stem[6:]))


def load_latest(run_dir: str | Path) -> tuple[dict, Path]:
    """The newest intact checkpoint of a run: ``latest.pt``, else (with a warning on
    stderr) the newest ``model_<it>.pt`` that loads.

    Returns:
        (checkpoint, the file it came from).

    Raises:
        FileNotFoundError: no checkpoint at all in ``run_dir``.
        ValueError: none that loads; the message names each file and why.
    """
    run_dir = Path(run_dir)
    candidates = [run_dir / LATEST, *reversed(numbered_checkpoints(run_dir))]
    problems = []
    for path in candidates:
        try:
            data = load_checkpoint(path)
        except (FileNotFoundError, ValueError) as err:
            problems.append(f"{path.name}: {err}")
            continue
        if path.name != LATEST:
            print(f"warning: {problems[0]}; using {path} instead", file=sys.stderr, flush=True)
        return data, path
    if len(candidates) == 1 and not candidates[0].is_file():
        raise FileNotFoundError(f"no checkpoint in {run_dir} (no {LATEST}, no model_*.pt)")
    raise ValueError(f"no intact checkpoint in {run_dir}: " + "; ".join(problems))


def read_run_config(run_dir: str | Path) -> dict:
    """A run's ``config.json``.

    Raises:
        FileNotFoundError: no such file.
        ValueError: the file is damaged (not a JSON object); the message names it.
    """
    path = Path(run_dir) / RUN_CONFIG
    if not path.is_file():
        raise FileNotFoundError(f"run settings not found: {path}")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"run settings {path} are damaged (not valid JSON: {err})") from None
    if not isinstance(data, dict) or not isinstance(data.get("train_config"), dict):
        raise ValueError(f"run settings {path} are damaged (no train_config object)")
    return data
