"""``policy.json``: the description an exported policy carries, and its checks.

Written by :func:`hybrid_recovery.training.export.export_policy`; every runner (control,
evaluation, ``play``, deploy) reads it through :func:`load_policy_description`, which
refuses a description of another format, robot or observation layout. No torch here.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from hybrid_recovery.observation import ACTOR_OBS_DIM, ACTOR_TERMS
from hybrid_recovery.robot import constants

POLICY_FORMAT = "hybrid_recovery.policy/1"
"""Version tag of ``policy.json``; runners refuse other formats."""


def check_meta(meta: dict, source: str) -> None:
    """Refuses a policy trained for other joints or another actor observation layout.

    Args:
        meta: ``joint_names`` (27 names, motor order) and ``actor_obs_dim`` (87).
        source: Where ``meta`` came from, for the message.

    Raises:
        ValueError: Other joints or another observation width.
    """
    if list(meta.get("joint_names", [])) != list(constants.JOINT_NAMES):
        raise ValueError(f"{source} was trained for joints {meta.get('joint_names')}, "
                         f"not the H1-2's {list(constants.JOINT_NAMES)}")
    if int(meta.get("actor_obs_dim", -1)) != ACTOR_OBS_DIM:
        raise ValueError(f"{source} expects an actor observation of {meta.get('actor_obs_dim')} "
                         f"entries; this version builds {ACTOR_OBS_DIM}")


def load_policy_description(path: str | Path) -> dict:
    """Reads a ``policy.json`` and checks every field a runner reads (type, range,
    finiteness), refusing one that does not match this robot and version.

    Fields: ``format``; ``observation.dim`` and ``observation.terms``; ``action.dim``,
    ``action.scale`` s > 0 [rad], ``action.target_range_factor`` in (0, 1] (optional);
    ``joint_names``; ``default_joint_pos``, ``kp``, ``kd`` (27 finite numbers equal to
    the robot constants) and ``effort_limits`` (27 finite numbers > 0 [N·m]);
    ``control_period_s`` > 0 [s]; ``delay_model_s`` (optional, [low, high] >= 0 [s]);
    ``provenance`` (optional object).

    Raises:
        FileNotFoundError: no such file.
        ValueError: one message naming the first bad field, e.g. ``<path> field
            'action.scale' must be a finite number > 0, got -0.3``; another format, other
            joints, another observation layout, other gains.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"policy description not found: {path}")
    try:
        desc = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ValueError(f"{path} is not valid JSON: {err}") from err
    if not isinstance(desc, dict):
        raise ValueError(f"{path} is not a JSON object")
    if desc.get("format") != POLICY_FORMAT:
        raise ValueError(f"{path} has format {desc.get('format')!r}, expected {POLICY_FORMAT!r}")
    field = _FieldReader(desc, path)
    field.get("observation", dict)
    field.get("action", dict)
    check_meta({"joint_names": field.get("joint_names", list),
                "actor_obs_dim": field.get("observation.dim", int)}, str(path))
    terms = field.get("observation.terms", list)
    if [list(t) if isinstance(t, list) else t for t in terms] != [list(t) for t in ACTOR_TERMS]:
        raise ValueError(f"{path} observation terms {terms} differ from "
                         f"this version's {[list(t) for t in ACTOR_TERMS]}")
    field.number("action.dim", constants.NUM_JOINTS, constants.NUM_JOINTS, integer=True)
    field.number("action.scale", 0.0, np.inf, open_low=True)
    if "target_range_factor" in desc["action"]:
        field.number("action.target_range_factor", 0.0, 1.0, open_low=True)
    for key, ref in (("default_joint_pos", constants.DEFAULT_JOINT_POS), ("kp", constants.KP),
                     ("kd", constants.KD)):
        if not np.allclose(field.numbers(key, constants.NUM_JOINTS), ref):
            raise ValueError(f"{path} {key} differs from the robot constants")
    field.numbers("effort_limits", constants.NUM_JOINTS, low=0.0)
    field.number("control_period_s", 0.0, np.inf, open_low=True)
    if "delay_model_s" in desc:
        low, high = field.numbers("delay_model_s", 2, low=0.0, closed=True)
        if low > high:
            raise ValueError(f"{path} field 'delay_model_s' must be [low, high] with low <= "
                             f"high, got {desc['delay_model_s']!r}")
    if desc.get("provenance") is not None:
        field.get("provenance", dict)
    return desc


class _FieldReader:
    """Reads dotted fields of a description, refusing a wrong type or range by name."""

    def __init__(self, desc: dict, path: Path) -> None:
        self.desc, self.path = desc, path

    def _refuse(self, key: str, what: str, value: Any) -> ValueError:
        return ValueError(f"{self.path} field '{key}' must be {what}, got {value!r}")

    def get(self, key: str, kind: type) -> Any:
        value: Any = self.desc
        for part in key.split("."):
            if not isinstance(value, dict) or part not in value:
                raise ValueError(f"{self.path} has no field '{key}'")
            value = value[part]
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            name = {dict: "an object", list: "a list", int: "an integer"}[kind]
            raise self._refuse(key, name, value)
        return value

    def number(self, key: str, low: float, high: float, open_low: bool = False,
               integer: bool = False) -> float:
        value = self.get(key, object)
        what = ("an integer" if integer else "a finite number") + (
            f" equal to {low:g}" if low == high else
            f" {'>' if open_low else '>='} {low:g}" + ("" if high == np.inf else
                                                      f" and <= {high:g}"))
        ok = (isinstance(value, int | float) and not isinstance(value, bool)
              and (not integer or isinstance(value, int)) and np.isfinite(value)
              and (value > low if open_low else value >= low) and value <= high)
        if not ok:
            raise self._refuse(key, what, value)
        return float(value)

    def numbers(self, key: str, count: int, low: float = -np.inf,
                closed: bool = False) -> np.ndarray:
        value = self.get(key, list)
        bound = "" if low == -np.inf else f" {'>=' if closed else '>'} {low:g}"
        ok = len(value) == count and all(
            isinstance(x, int | float) and not isinstance(x, bool) and np.isfinite(x)
            and (x >= low if closed else x > low) for x in value)
        if not ok:
            raise self._refuse(key, f"a list of {count} finite numbers{bound}", value)
        return np.asarray(value, dtype=float)
