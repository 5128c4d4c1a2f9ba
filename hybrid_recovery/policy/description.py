"""``policy.json``: the description an exported policy carries, and its checks.

Written by :func:`hybrid_recovery.training.export.export_policy`; every runner (control,
evaluation, ``play``, deploy) reads it through :func:`load_policy_description`, which
refuses a description of another format, robot or observation layout. No torch here.
"""

from __future__ import annotations

import json
from pathlib import Path

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
    """Reads a ``policy.json`` and refuses one that does not match this robot and version.

    Raises:
        FileNotFoundError: no such file.
        ValueError: another format, other joints, another observation layout, other gains.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"policy description not found: {path}")
    try:
        desc = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is not valid JSON: {err}") from err
    if desc.get("format") != POLICY_FORMAT:
        raise ValueError(f"{path} has format {desc.get('format')!r}, expected {POLICY_FORMAT!r}")
    check_meta({"joint_names": desc.get("joint_names"),
                "actor_obs_dim": desc.get("observation", {}).get("dim")}, str(path))
    if [list(t) for t in desc["observation"]["terms"]] != [list(t) for t in ACTOR_TERMS]:
        raise ValueError(f"{path} observation terms {desc['observation']['terms']} differ from "
                         f"this version's {[list(t) for t in ACTOR_TERMS]}")
    for key, ref in (("default_joint_pos", constants.DEFAULT_JOINT_POS), ("kp", constants.KP),
                     ("kd", constants.KD)):
        if not np.allclose(desc[key], ref):
            raise ValueError(f"{path} {key} differs from the robot constants")
    return desc
