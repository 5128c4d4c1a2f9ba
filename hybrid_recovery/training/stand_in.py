"""Stand-in policies with a valid ``policy.json``, for tests and timing without a trained run.

``zero`` always outputs a = 0, i.e. q_ref = q*: under the constants' PD the robot stands.
``random`` has the trained actor's shape (87 → 512 → 256 → 128 → 27, ELU) with random
weights, for inference timing.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Literal

from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.robot import constants

HIDDEN_DIMS = (512, 256, 128)
"""Hidden layers of the stand-in (= the training default, ``TrainConfig.hidden_dims``)."""


def write_stand_in_policy(out_dir: str | Path, kind: Literal["zero", "random"] = "zero",
                          seed: int = 0) -> Path:
    """Writes ``policy.onnx`` and ``policy.json`` of a stand-in policy; returns ``out_dir``."""
    import torch

    from hybrid_recovery.envs import default_config
    from hybrid_recovery.training.export import policy_description

    if kind not in ("zero", "random"):
        raise ValueError(f"kind must be 'zero' or 'random', got {kind!r}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    dims = (ACTOR_OBS_DIM, *HIDDEN_DIMS)
    layers: list[torch.nn.Module] = []
    for a, b in zip(dims[:-1], dims[1:], strict=True):
        layers += [torch.nn.Linear(a, b), torch.nn.ELU()]
    head = torch.nn.Linear(dims[-1], constants.NUM_JOINTS)
    if kind == "zero":
        torch.nn.init.zeros_(head.weight)
        torch.nn.init.zeros_(head.bias)
    net = torch.nn.Sequential(*layers, head).eval()
    torch.onnx.export(net, (torch.zeros(1, ACTOR_OBS_DIM),), str(out / "policy.onnx"),
                      input_names=["obs"], output_names=["actions"], opset_version=18,
                      dynamo=False)
    meta = {"env_config": dataclasses.asdict(default_config()), "variant": f"stand-in-{kind}",
            "git_commit": "none"}
    (out / "policy.json").write_text(json.dumps(policy_description(meta, None, None), indent=2))
    return out
