"""Type and range checks of configuration values set by name (``--set key=value``).

:func:`checked_value` turns a JSON-parsed value into the value of a dataclass field's
declared type, or refuses it naming the key: ``config key 'physics_dt' must be > 0, got
0``. EnvConfig keys are dotted paths; ``ppo.<field>`` and ``train.<field>`` are the
amendable training settings (``train --amend``). Infinity is a number here (several
fields use it for "no limit"); NaN never is.
"""

from __future__ import annotations

import math
import types
import typing
from typing import Any

RANGES: dict[str, tuple[float, bool, float]] = {
    "num_envs": (1, True, math.inf),
    "num_threads": (0, True, math.inf),
    "physics_dt": (0.0, False, math.inf),
    "decimation": (1, True, math.inf),
    "episode_length_s": (0.0, False, math.inf),
    "action_scale": (0.0, False, math.inf),
    "delay_range": (0.0, True, math.inf),
    "pose_weights": (0.0, True, math.inf),
    "torso_force_limit": (0.0, False, math.inf),
    "stuck_time": (0.0, False, math.inf),
    "stuck_rise": (0.0, True, math.inf),
    "upright_height": (0.0, False, math.inf),
    "rewards.sigma_height": (0.0, False, math.inf),
    "rewards.sigma_com": (0.0, False, math.inf),
    "rewards.sigma_cp": (0.0, False, math.inf),
    "rewards.height_band": (0.0, True, math.inf),
    "rewards.feet_flat": (0.0, True, math.inf),
    "noise.ang_vel": (0.0, True, math.inf),
    "noise.gravity": (0.0, True, math.inf),
    "noise.joint_pos": (0.0, True, math.inf),
    "noise.joint_vel": (0.0, True, math.inf),
    "domain_rand.init_base_pos": (0.0, True, math.inf),
    "domain_rand.init_base_rot": (0.0, True, math.inf),
    "domain_rand.init_joint_pos": (0.0, True, math.inf),
    "pushes.duration": (0.0, False, math.inf),
    "pushes.interval": (0.0, False, math.inf),
    "pushes.fall_probability": (0.0, True, 1.0),
    "pushes.upright_time": (0.0, True, math.inf),
    "curriculum.torque_scale_explore": (0.0, False, math.inf),
    "curriculum.position_limit_final": (0.0, False, 1.0),
    "curriculum.window": (1, True, math.inf),
    "curriculum.step": (0.0, False, 1.0),
    "assist.fraction": (0.0, True, math.inf),
    "assist.decay": (0.0, True, 1.0),
    "assist.floor": (0.0, True, math.inf),
    "bridge.levels": (0, True, math.inf),
    "bridge.window": (1, True, math.inf),
    "rises.levels": (1, True, math.inf),
    "rises.advance": (0.0, False, 1.0),
    "rises.retreat": (0.0, True, 1.0),
    "rises.window": (1, True, math.inf),
    "ppo.clip_param": (0.0, False, math.inf),
    "ppo.gamma": (0.0, False, 1.0),
    "ppo.lam": (0.0, True, 1.0),
    "ppo.learning_rate": (0.0, False, math.inf),
    "ppo.desired_kl": (0.0, False, math.inf),
    "ppo.entropy_coef": (0.0, True, math.inf),
    "ppo.value_loss_coef": (0.0, True, math.inf),
    "ppo.num_learning_epochs": (1, True, math.inf),
    "ppo.num_mini_batches": (1, True, math.inf),
    "ppo.max_grad_norm": (0.0, False, math.inf),
    "train.max_std": (0.0, False, math.inf),
    "train.save_interval": (1, True, math.inf),
    "train.keep_checkpoints": (1, True, math.inf),
    "train.num_steps_per_env": (1, True, math.inf),
    "train.torch_threads": (1, True, math.inf),
}
"""Key → (lower bound, lower bound allowed, upper bound allowed) of every number in the
value (each entry of a pair or a table); keys not listed take any number but NaN."""


class _Refused(Exception):
    def __init__(self, expected: str) -> None:
        super().__init__(expected)
        self.expected = expected


def checked_value(dotted: str, value: Any, hint: Any) -> Any:
    """``value`` as the declared type ``hint`` of the field ``dotted``, range-checked.

    Args:
        dotted: The dotted key, for the message and :data:`RANGES`.
        value: The JSON-parsed value (lists for tuples).
        hint: The field's resolved type annotation.

    Raises:
        ValueError: ``config key '<dotted>' must be <what>, got <value>``.
    """
    try:
        out = _coerce(value, hint)
    except _Refused as err:
        raise ValueError(f"config key '{dotted}' must be {err.expected}, got {value!r}") from None
    if dotted in RANGES:
        lo, closed, hi = RANGES[dotted]
        for x in _numbers(out):
            if not (x >= lo if closed else x > lo) or x > hi:
                bound = f"{'>=' if closed else '>'} {lo:g}" + ("" if hi == math.inf
                                                              else f" and <= {hi:g}")
                raise ValueError(f"config key '{dotted}' must be {bound}, got {value!r}")
        if isinstance(out, tuple) and len(out) == 2 and all(isinstance(x, float) for x in out) \
                and out[0] > out[1]:
            raise ValueError(f"config key '{dotted}' must be a (low, high) pair with low <= "
                             f"high, got {value!r}")
    return out


def _numbers(value: Any) -> list[float]:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return []
    if isinstance(value, int | float):
        return [value]
    if isinstance(value, dict):
        return [x for v in value.values() for x in _numbers(v)]
    if isinstance(value, list | tuple):
        return [x for v in value for x in _numbers(v)]
    return []


def _coerce(value: Any, hint: Any) -> Any:
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        try:
            return _coerce(value, inner)
        except _Refused as err:
            raise _Refused(f"{err.expected} or null") from None
    if hint is bool:
        if not isinstance(value, bool):
            raise _Refused("true or false")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise _Refused("an integer")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
            raise _Refused("a number")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise _Refused("a string")
        return value
    if origin in (tuple, list):
        if not isinstance(value, list | tuple):
            raise _Refused(f"like {_shape(hint)}")
        if origin is tuple and not (len(args) == 2 and args[1] is Ellipsis):
            if len(value) != len(args):
                raise _Refused(f"like {_shape(hint)}")
            items = [_item(v, a, hint) for v, a in zip(value, args, strict=True)]
        else:
            items = [_item(v, args[0], hint) for v in value]
        return tuple(items) if origin is tuple else items
    if origin is dict:
        if not isinstance(value, dict):
            raise _Refused(f"like {_shape(hint)}")
        return {_item(k, args[0], hint): _item(v, args[1], hint) for k, v in value.items()}
    return value  # a nested config object: not set by name


def _item(value: Any, hint: Any, whole: Any) -> Any:
    try:
        return _coerce(value, hint)
    except _Refused:
        raise _Refused(f"like {_shape(whole)}") from None


def _shape(hint: Any) -> str:
    """The JSON shape of a type: ``[number, number]``, ``[string, ...]``, ``{string: number}``."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis or origin is list:
        return f"[{_shape(args[0])}, ...]"
    if origin is tuple:
        return "[" + ", ".join(_shape(a) for a in args) + "]"
    if origin is dict:
        return f"{{{_shape(args[0])}: {_shape(args[1])}}}"
    return {bool: "true", int: "integer", float: "number", str: "string"}.get(hint, "value")
