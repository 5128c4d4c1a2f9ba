"""Every number of the getup, control and environment configs is checked finite and in
range where the dataclass is constructed; ``--set`` is refused at the edge with the same
table; recorded rises are checked for quaternion norms, shapes and types."""

from __future__ import annotations

import dataclasses
import math
import typing
from pathlib import Path

import numpy as np
import pytest

from hybrid_recovery.checks import check_fields
from hybrid_recovery.cli.main import main
from hybrid_recovery.control import config as control_config
from hybrid_recovery.envs import config as env_config
from hybrid_recovery.envs.config_values import INFINITE, RANGES
from hybrid_recovery.envs.rise_starts import load_rises
from hybrid_recovery.getup import move_executor
from hybrid_recovery.getup.contact_qp import ContactQpConfig
from hybrid_recovery.getup.contact_tasks import ContactTaskGains
from hybrid_recovery.getup.feasibility import FeasibilityConfig
from hybrid_recovery.getup.kneel_move import KneelMoveConfig
from hybrid_recovery.getup.move_executor import MoveConfig
from hybrid_recovery.getup.push_up import PushUpConfig
from hybrid_recovery.getup.relapse import GetupConfig
from hybrid_recovery.getup.to_squat import ToSquatConfig

CONFIGS = [FeasibilityConfig, ContactQpConfig, ContactTaskGains, PushUpConfig, ToSquatConfig,
           KneelMoveConfig, MoveConfig, GetupConfig, control_config.QpConfig,
           control_config.DcmConfig, control_config.SteppingConfig, control_config.BalanceConfig,
           control_config.SupervisorConfig,
           env_config.RewardConfig, env_config.NoiseConfig, env_config.DomainRandConfig,
           env_config.PushConfig, env_config.CurriculumConfig, env_config.AssistConfig,
           env_config.BridgeConfig, env_config.RiseConfig, env_config.EnvConfig]
"""Every config dataclass of getup, control and envs."""
SECTIONS = {"rewards": env_config.RewardConfig, "noise": env_config.NoiseConfig,
            "domain_rand": env_config.DomainRandConfig, "pushes": env_config.PushConfig,
            "curriculum": env_config.CurriculumConfig, "assist": env_config.AssistConfig,
            "bridge": env_config.BridgeConfig, "rises": env_config.RiseConfig}
"""EnvConfig key prefix → section."""


def _number_fields(cls) -> list[tuple[str, typing.Any]]:
    hints = typing.get_type_hints(cls)

    def numeric(hint) -> bool:
        return hint in (int, float) or any(numeric(a) for a in typing.get_args(hint)
                                           if a is not Ellipsis)

    return [(f.name, hints[f.name]) for f in dataclasses.fields(cls) if numeric(hints[f.name])]


def _with(value: float, hint, default):
    """``value`` shaped as the field's default (every entry of a pair or a table)."""
    if isinstance(default, dict):
        return dict.fromkeys(default, value)
    if isinstance(default, tuple | list):
        return type(default)(value for _ in default)
    return value


def _cases(bad: float):
    for cls in CONFIGS:
        for name, hint in _number_fields(cls):
            default = getattr(cls(), name)
            if bad == math.inf and (any(RANGES_KEY(cls, name) == key for key in INFINITE)
                                    or (cls is MoveConfig and name in move_executor.INFINITE)):
                continue
            if hint is int or typing.get_args(hint) == (int,):
                continue  # an int field takes no NaN or inf: refused as not an integer
            yield pytest.param(cls, name, _with(bad, hint, default), id=f"{cls.__name__}.{name}")


def RANGES_KEY(cls, name: str) -> str:  # noqa: N802 - the RANGES key of an EnvConfig field
    prefix = {v: k for k, v in SECTIONS.items()}.get(cls)
    return f"{prefix}.{name}" if prefix else name


def test_every_config_constructs_with_its_defaults():
    for cls in CONFIGS:
        cls()


@pytest.mark.parametrize(("cls", "name", "value"), list(_cases(math.nan)))
def test_nan_is_refused_in_every_number_field(cls, name, value):
    with pytest.raises(ValueError) as info:
        cls(**{name: value})
    assert str(info.value) == f"{cls.__name__}.{name} must be finite, got nan"


@pytest.mark.parametrize(("cls", "name", "value"), list(_cases(math.inf)))
def test_infinity_is_refused_but_where_it_means_no_limit(cls, name, value):
    with pytest.raises(ValueError) as info:
        cls(**{name: value})
    assert str(info.value) == f"{cls.__name__}.{name} must be finite, got inf"


def test_no_limit_fields_take_infinity():
    assert INFINITE == {"assist.max_height"}
    assert env_config.AssistConfig(max_height=math.inf).max_height == math.inf
    assert move_executor.INFINITE == ("prone_lean",)
    assert MoveConfig().prone_lean == math.inf  # the hybrid's moves: never


def test_every_number_of_the_env_config_has_a_range():
    keys = [name for name, _ in _number_fields(env_config.EnvConfig)]
    keys += [f"{prefix}.{name}" for prefix, cls in SECTIONS.items()
             for name, _ in _number_fields(cls)]
    assert [key for key in keys if key not in RANGES] == []


def test_a_nan_floor_is_refused_before_it_makes_the_head_a_support():
    # with floor_height = nan every contact's gap comparison was False, so every named
    # contact counted as touching: the head 1.6 m up held the robot
    with pytest.raises(ValueError) as info:
        FeasibilityConfig(floor_height=float("nan"))
    assert str(info.value) == "FeasibilityConfig.floor_height must be finite, got nan"
    assert FeasibilityConfig(floor_height=-0.02).floor_height == -0.02


@pytest.mark.parametrize(("make", "message"), [
    (lambda: ContactQpConfig(friction=0.0), "ContactQpConfig.friction must be > 0, got 0.0"),
    (lambda: ContactQpConfig(max_iter=0), "ContactQpConfig.max_iter must be >= 1, got 0"),
    (lambda: PushUpConfig(range_factor=1.5),
     "PushUpConfig.range_factor must be > 0 and <= 1, got 1.5"),
    (lambda: ContactTaskGains(kp_posture=-1.0),
     "ContactTaskGains.kp_posture must be >= 0, got -1.0"),
    (lambda: PushUpConfig(gains=ContactTaskGains(w_landing=-1.0)),
     "ContactTaskGains.w_landing must be >= 0, got -1.0"),
    (lambda: ToSquatConfig(support_depth=2.0),
     "ToSquatConfig.support_depth must be >= 0 and <= 1, got 2.0"),
    (lambda: ToSquatConfig(time_scale=0.0), "ToSquatConfig.time_scale must be > 0, got 0.0"),
    (lambda: KneelMoveConfig(bow_settle=-1.0), "KneelMoveConfig.bow_settle must be >= 0, got -1.0"),
    (lambda: KneelMoveConfig(range_factor=0.0),
     "KneelMoveConfig.range_factor must be > 0 and <= 1, got 0.0"),
    (lambda: GetupConfig(relapse_time=-1.0), "GetupConfig.relapse_time must be >= 0, got -1.0"),
    (lambda: control_config.QpConfig(friction="0.6"),
     "QpConfig.friction must be a number, got '0.6'"),
    (lambda: control_config.QpConfig(max_iter=2.5),
     "QpConfig.max_iter must be an integer, got 2.5"),
    (lambda: control_config.SteppingConfig(replan_until=1.5),
     "SteppingConfig.replan_until must be >= 0 and <= 1, got 1.5"),
    (lambda: env_config.RewardConfig(w_cp=1e300),
     "RewardConfig.w_cp must be >= -1e+06 and <= 1e+06, got 1e+300"),
    (lambda: env_config.DomainRandConfig(kp_scale=(1.25, 0.75)),
     "DomainRandConfig.kp_scale must be a (low, high) pair with low <= high, got (1.25, 0.75)"),
    (lambda: env_config.EnvConfig(pose_weights={"standing": -1.0}),
     "EnvConfig.pose_weights must be >= 0, got -1.0"),
    (lambda: env_config.RiseConfig(advance=0.1),
     "RiseConfig.retreat must be < advance, got retreat 0.15 and advance 0.1"),
])
def test_range_messages(make, message):
    with pytest.raises(ValueError) as info:
        make()
    assert str(info.value) == message


def test_check_fields_names_the_class_and_field():
    @dataclasses.dataclass
    class Probe:
        gain: float = 1.0
        pair: tuple[float, float] = (0.0, 1.0)

        def __post_init__(self) -> None:
            check_fields(self, {"gain": (0.0, False, 10.0)}, pairs={"pair"})

    with pytest.raises(ValueError, match=r"^Probe.gain must be > 0 and <= 10, got 11.0$"):
        Probe(gain=11.0)
    with pytest.raises(ValueError, match=r"^Probe.pair must be finite, got -inf$"):
        Probe(pair=(-math.inf, 0.0))


def test_a_huge_reward_weight_is_refused_at_the_edge(tmp_path, capsys):
    run = tmp_path / "run"
    assert main(["train", "--run-dir", str(run), "--num-envs", "2", "--iterations", "1",
                 "--set", "rewards.w_cp=1e300"]) == 2
    assert capsys.readouterr().err == ("error: config key 'rewards.w_cp' must be >= -1e+06 "
                                       "and <= 1e+06, got 1e+300\n")
    assert not run.exists()


def test_set_refuses_infinity_but_where_it_means_no_limit():
    from hybrid_recovery.envs import apply_overrides, default_config

    with pytest.raises(ValueError) as info:
        apply_overrides(default_config(), {"physics_dt": math.inf})
    assert str(info.value) == "config key 'physics_dt' must be finite, got inf"
    assert apply_overrides(default_config(),
                           {"assist.max_height": math.inf}).assist.max_height == math.inf


# ---------------------------------------------------------------- recorded rises
NQ, NV = 34, 33
PHASES = ["settle"] * 2 + ["tuck/knee_chest"] * 16 + ["policy"] * 2


def _recording(path: Path, **replace) -> Path:
    count = 2 * len(PHASES)
    qpos = np.zeros((count, NQ))
    qpos[:, 3] = 1.0
    arrays = dict(qpos=qpos, qvel=np.zeros((count, NV)),
                  time=np.tile(np.arange(len(PHASES)) * 0.02, 2),
                  episode=np.repeat(np.arange(2), len(PHASES)), phase=np.array(PHASES * 2),
                  pose=np.array("sitting"))
    arrays.update(replace)
    np.savez_compressed(path, **arrays)
    return path


def test_a_recording_with_zero_base_quaternions_names_the_file_and_episode(tmp_path):
    qpos = np.zeros((2 * len(PHASES), NQ))
    qpos[:len(PHASES), 3] = 1.0  # episode 1 was written with zero quaternions
    path = _recording(tmp_path / "zero_quat.npz", qpos=qpos)
    with pytest.raises(ValueError) as info:
        load_rises(path, 4, NQ, NV)
    assert str(info.value) == (f"rise recording {path}: episode 1 has a base quaternion "
                               f"qpos[3:7] of norm 0 at 0.00 s (sample 20; 20 samples off "
                               f"1 ± 0.01)")
    assert load_rises(_recording(tmp_path / "good.npz"), 4, NQ, NV)[0] == "sitting"


@pytest.mark.parametrize(("replace", "message"), [
    ({"episode": np.repeat(np.arange(2.0), len(PHASES))},
     "episode must hold integers, got dtype float64"),
    ({"phase": np.zeros(2 * len(PHASES), int)}, "phase must hold strings, got dtype int64"),
    ({"time": np.array(["0.0"] * 2 * len(PHASES))}, "time must hold real numbers, got dtype "
                                                    "<U3"),
    ({"pose": np.array(["sitting", "prone"])}, "pose must be one string, got shape (2,)"),
])
def test_a_recording_of_wrong_types_is_named(tmp_path, replace, message):
    path = _recording(tmp_path / "bad.npz", **replace)
    with pytest.raises(ValueError) as info:
        load_rises(path, 4, NQ, NV)
    assert str(info.value) == f"rise recording {path}: {message}"


def test_one_entry_of_a_dict_field_is_set_by_its_dotted_key():
    """``--set pose_weights.sitting=2`` (training/README.md) sets one pose's weight."""
    from hybrid_recovery.envs import apply_overrides, default_config

    cfg = default_config()
    others = {k: v for k, v in cfg.pose_weights.items() if k != "sitting"}
    apply_overrides(cfg, {"pose_weights.sitting": 2})
    assert cfg.pose_weights == {**others, "sitting": 2.0}
    with pytest.raises(ValueError) as err:
        apply_overrides(cfg, {"pose_weights.sitting": -1})
    assert str(err.value) == "config key 'pose_weights.sitting' must be >= 0, got -1"
    with pytest.raises(KeyError) as missing:
        apply_overrides(cfg, {"pose_weights.flying": 1})
    assert missing.value.args[0] == (
        "unknown config key 'pose_weights.flying': 'flying' is not one of ['half_kneeling', "
        "'kneeling', 'prone', 'sitting', 'squatting', 'standing', 'supine']")
    assert cfg.pose_weights["sitting"] == 2.0  # a refused entry changes nothing
