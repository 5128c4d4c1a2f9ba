"""Type and range checks of configuration values set by name (``--set key=value``).

:func:`checked_value` turns a JSON-parsed value into the value of a dataclass field's
declared type, or refuses it naming the key: ``config key 'physics_dt' must be > 0, got
0``. EnvConfig keys are dotted paths; ``ppo.<field>`` and ``train.<field>`` are the
amendable training settings (``train --amend``). A number must be finite (infinity only
where a field uses it for "no limit", :data:`INFINITE`), and NaN never is.

The same table checks every EnvConfig section when it is constructed
(:func:`check_section`).
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any

from hybrid_recovery.checks import (
    NON_NEGATIVE,
    POSITIVE,
    UNIT,
    Range,
    bound_text,
    check_fields,
    in_range,
)

WEIGHT: Range = (-1e6, True, 1e6)
"""A reward weight w: a reward per second of the condition holding, either sign."""
COEFFICIENT: Range = (0.0, True, 1e6)
"""A shaping coefficient α or a penalty scale: ≥ 0, small enough that α × a physical
quantity stays finite in float32."""

RANGES: dict[str, Range] = {
    "num_envs": (1, True, math.inf),
    "num_threads": (0, True, math.inf),
    "seed": (0, True, 2**63 - 1),
    "physics_dt": POSITIVE,
    "decimation": (1, True, math.inf),
    "episode_length_s": POSITIVE,
    "action_scale": POSITIVE,
    "delay_range": NON_NEGATIVE,
    "pose_weights": NON_NEGATIVE,
    "torso_force_limit": POSITIVE,
    "stuck_time": POSITIVE,
    "stuck_rise": NON_NEGATIVE,
    "upright_height": POSITIVE,
    "actuator_saturation": POSITIVE,
    "rewards.height_target": POSITIVE,
    "rewards.w_height": WEIGHT,
    "rewards.sigma_height": POSITIVE,
    "rewards.w_rise": WEIGHT,
    "rewards.alpha_rise": COEFFICIENT,
    "rewards.w_fall": WEIGHT,
    "rewards.alpha_fall": COEFFICIENT,
    "rewards.w_stab": WEIGHT,
    "rewards.alpha_stab": COEFFICIENT,
    "rewards.alpha_stab_vel": COEFFICIENT,
    "rewards.height_band": NON_NEGATIVE,
    "rewards.w_com": WEIGHT,
    "rewards.sigma_com": POSITIVE,
    "rewards.w_cp": WEIGHT,
    "rewards.sigma_cp": POSITIVE,
    "rewards.w_mom": WEIGHT,
    "rewards.alpha_lin": COEFFICIENT,
    "rewards.alpha_ang": COEFFICIENT,
    "rewards.w_torque": WEIGHT,
    "rewards.w_joint_limit": WEIGHT,
    "rewards.w_joint_speed": WEIGHT,
    "rewards.w_action_rate": WEIGHT,
    "rewards.w_orient": WEIGHT,
    "rewards.w_contact": WEIGHT,
    "rewards.contact_gate_height": NON_NEGATIVE,
    "rewards.w_feet": WEIGHT,
    "rewards.feet_flat": (0.0, True, 0.99),
    "rewards.w_alive": WEIGHT,
    "rewards.w_termination": WEIGHT,
    "noise.ang_vel": NON_NEGATIVE,
    "noise.gravity": NON_NEGATIVE,
    "noise.joint_pos": NON_NEGATIVE,
    "noise.joint_vel": NON_NEGATIVE,
    "domain_rand.kp_scale": POSITIVE,
    "domain_rand.kd_scale": NON_NEGATIVE,
    "domain_rand.joint_friction": NON_NEGATIVE,
    "domain_rand.armature_scale": NON_NEGATIVE,
    "domain_rand.static_friction": POSITIVE,
    "domain_rand.dynamic_friction": POSITIVE,
    "domain_rand.restitution": UNIT,
    "domain_rand.mass_scale": POSITIVE,
    "domain_rand.inertia_scale": POSITIVE,
    "domain_rand.init_base_pos": NON_NEGATIVE,
    "domain_rand.init_base_rot": NON_NEGATIVE,
    "domain_rand.init_joint_pos": NON_NEGATIVE,
    "pushes.force": NON_NEGATIVE,
    "pushes.duration": POSITIVE,
    "pushes.interval": POSITIVE,
    "pushes.fall_force": NON_NEGATIVE,
    "pushes.fall_probability": UNIT,
    "pushes.upright_time": NON_NEGATIVE,
    "curriculum.torque_scale_explore": POSITIVE,
    "curriculum.position_limit_final": (0.0, False, 1.0),
    "curriculum.advance_success": NON_NEGATIVE,  # above 1: the curriculum never advances
    "curriculum.window": (1, True, math.inf),
    "curriculum.step": (0.0, False, 1.0),
    "assist.fraction": NON_NEGATIVE,
    "assist.decay": UNIT,
    "assist.floor": NON_NEGATIVE,
    "assist.max_tilt": POSITIVE,
    "assist.max_height": POSITIVE,
    "bridge.levels": (0, True, math.inf),
    "bridge.advance": (0.0, False, 1.0),
    "bridge.retreat": UNIT,
    "bridge.window": (1, True, math.inf),
    "rises.levels": (1, True, math.inf),
    "rises.advance": (0.0, False, 1.0),
    "rises.retreat": UNIT,
    "rises.window": (1, True, math.inf),
    "terrain.weights": NON_NEGATIVE,
    "terrain.max_slope": (0.0, False, 45.0),
    "terrain.max_rough": (0.0, False, 0.2),
    "terrain.rough_levels": (1, True, 50),
    "terrain.max_step": (0.0, False, 0.3),
    "terrain.advance": (0.0, False, 1.0),
    "terrain.retreat": UNIT,
    "terrain.window": (1, True, math.inf),
    "terrain.step": (0.0, False, 1.0),
    "terrain.start_level": UNIT,
    "terrain.height_grid": (1, True, 51),
    "terrain.height_spacing": POSITIVE,
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
"""Key → range (:data:`~hybrid_recovery.checks.Range`) of every number in the value (each
entry of a pair or a table). Every number of an EnvConfig is listed; a key not listed
takes any finite number."""

INFINITE = frozenset({"assist.max_height"})
"""Keys whose value may be infinity (a "no limit"); every other number must be finite."""


def check_section(config: Any, prefix: str) -> None:
    """Checks every number of an EnvConfig section at its construction against
    :data:`RANGES` (keys ``<prefix><field>``); its (low, high) pairs must be ordered.

    Args:
        config: The section (``RewardConfig``, ..., or the EnvConfig itself).
        prefix: Its dotted key prefix: ``"rewards."``, ..., ``""`` for the EnvConfig.

    Raises:
        ValueError: ``<Class>.<field> must be <range>, got <value>`` (see
            :func:`~hybrid_recovery.checks.check_fields`).
    """
    names = [f.name for f in dataclasses.fields(config)]
    hints = typing.get_type_hints(type(config))
    check_fields(config, {n: RANGES[prefix + n] for n in names if prefix + n in RANGES},
                 infinite={n for n in names if prefix + n in INFINITE},
                 pairs={n for n in names if hints[n] == tuple[float, float]})


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
    for x in _numbers(out):
        if math.isinf(x) and dotted not in INFINITE:
            raise ValueError(f"config key '{dotted}' must be finite, got {value!r}")
    if dotted in RANGES:
        bounds = RANGES[dotted]
        for x in _numbers(out):
            if not in_range(x, bounds):
                raise ValueError(f"config key '{dotted}' must be {bound_text(bounds)}, "
                                 f"got {value!r}")
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
    if origin is typing.Literal:
        if value not in args:
            raise _Refused("one of " + ", ".join(repr(a) for a in args))
        return value
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
