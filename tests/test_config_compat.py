"""Old configs still load: removed options at their neutral values are dropped, others are
refused; the live checkpoint's run and the shipped policy's record load; the shipped
policy's final settings are the last stage of the named variant ``recovery_rises``."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest

from hybrid_recovery.envs.assist import Assist
from hybrid_recovery.envs.config import EnvConfig
from hybrid_recovery.envs.curriculum import Curriculum
from hybrid_recovery.envs.pose_bridge import PoseBridge
from hybrid_recovery.envs.removed import REMOVED, drop_removed, env_config_from_dict
from hybrid_recovery.policy import SHIPPED_POLICY
from hybrid_recovery.training.checkpoint import load_checkpoint
from hybrid_recovery.training.config import amend_train_config, train_config_from_dict
from hybrid_recovery.training.runner import _resumed_config, make_env_config
from hybrid_recovery.training.stages import StageState, stage_config
from hybrid_recovery.training.variants import VARIANTS, variant_train_config

ROOT = Path(__file__).resolve().parents[1]
LIVE_RUN = ROOT / "training" / "checkpoints" / "recovery_model_rises_s0"
RECORD = SHIPPED_POLICY / "training_record.json"


def _plain(cfg) -> dict:
    """A config as JSON would hold it (tuples as lists, inf as Infinity)."""
    return json.loads(json.dumps(dataclasses.asdict(cfg)))


def test_removed_keys_at_their_neutral_values_are_dropped():
    saved = {"rewards.w_shin": 0.0, "rewards.rise_vel_max": math.inf, "assist.mode": "pull",
             "assist.stuck_time": None, "bridge.mix": 0.0, "bridge.stuck_time": None,
             "replay.fraction": 0.0, "replay.poses": ["supine"], "rewards.w_cp": 0.5}
    assert drop_removed(saved) == {"rewards.w_cp": 0.5}


@pytest.mark.parametrize("key,value", [("rewards.w_shin", 1.0), ("assist.mode", "gravity"),
                                       ("bridge.mix", 0.25), ("replay.fraction", 0.2),
                                       ("assist.stuck_time", 6.0)])
def test_a_removed_key_in_use_is_refused(key, value):
    with pytest.raises(ValueError) as err:
        drop_removed({key: value})
    assert str(err.value) == (
        f"'{key}' was removed from the environment; this config sets it to {value!r}, and "
        f"only its neutral value {REMOVED[key]!r} can load (docs/experiments.md says what "
        "it did)")


def test_a_saved_env_config_with_removed_sections_loads_and_unknown_keys_do_not():
    saved = _plain(EnvConfig())
    saved["replay"] = {"fraction": 0.0, "poses": None, "interval_s": 0.5, "capacity": 4096}
    saved["rewards"]["w_shin"] = 0.0
    saved["bridge"]["mix"] = 0.0
    assert _plain(env_config_from_dict(saved)) == _plain(EnvConfig())
    saved["rewards"]["w_knees"] = 1.0
    with pytest.raises(KeyError, match="unknown config key 'rewards.w_knees'"):
        env_config_from_dict(saved)
    saved["rewards"].pop("w_knees")
    saved["replay"]["fraction"] = 0.5
    with pytest.raises(ValueError, match="'replay.fraction' was removed"):
        env_config_from_dict(saved)


def test_the_shipped_record_loads():
    record = json.loads(RECORD.read_text())
    env = env_config_from_dict(record["env_config"])
    assert env.rises.levels == 16 and env.assist.poses == ["prone"]
    train_cfg = train_config_from_dict(record["train_config"])
    assert train_cfg.max_std == 0.6 and train_cfg.teacher.learning_rate == 1e-4


def test_the_live_checkpoints_run_resumes_with_its_saved_settings():
    """The live run is the recipe from nothing: a staged run whose saved settings, stage
    and curriculum states resume as they were."""
    if not (LIVE_RUN / "config.json").is_file():
        pytest.skip("no live checkpoint in this tree")
    saved = json.loads((LIVE_RUN / "config.json").read_text())
    resumed = _resumed_config(LIVE_RUN, variant_train_config("full"), given=set())
    assert resumed == train_config_from_dict(saved["train_config"])
    assert resumed.variant == "recovery_model_rises" and resumed.stages is not None
    assert saved["amendments"] == []  # from scratch: no amendment
    state = StageState.load(LIVE_RUN)
    assert state is not None and state.stage == saved["stage"]
    env_cfg = make_env_config(stage_config(resumed, state.stage, LIVE_RUN, resumed.stages))
    resumed_env, saved_env = _plain(env_cfg), _plain(env_config_from_dict(saved["env_config"]))
    # the recordings are the run's own, <run>/rises/<pose>.npz, wherever the run lies
    for env in (resumed_env, saved_env):
        env["rises"]["files"] = [Path(f).relative_to(Path(f).parents[1]).as_posix()
                                 for f in env["rises"]["files"]]
    assert resumed_env == saved_env
    for file in env_cfg.rises.files:
        assert Path(file).is_file()  # shipped with the checkpoint: a resume trains on them
    # the checkpoint's curriculum, assistance and bridge states load into the run's own
    infos = load_checkpoint(LIVE_RUN / "latest.pt")["infos"]
    curriculum, bridge = Curriculum(env_cfg.curriculum), PoseBridge(env_cfg.bridge)
    assist = Assist(env_cfg.assist, env_cfg.curriculum.window, 0.6)
    curriculum.load_state_dict(infos["curriculum"])
    assist.load_state_dict(infos["assist"])
    bridge.load_state_dict(infos["bridge"])
    assert (curriculum.stage, curriculum.level) == (infos["curriculum"]["stage"],
                                                    infos["curriculum"]["level"])
    assert assist.fraction == infos["assist"]["fraction"]
    for pose, level in infos["bridge"]["level"].items():
        assert bridge.level[pose] == level
        assert len(bridge._outcomes[pose]) == len(infos["bridge"]["outcomes"][pose])


def test_the_recipes_last_stage_is_the_shipped_recipe():
    """``--variant recovery_rises`` in its ``rises`` stage gives the record's train and env
    configs (the record's config is its run's with every amendment applied), and applying
    the amendments once more changes nothing."""
    record = json.loads(RECORD.read_text())
    recipe = variant_train_config("recovery_rises")
    assert recipe.stages is not None
    ours = stage_config(recipe, "rises", Path("."), recipe.stages)
    ours = dataclasses.replace(ours, env_overrides={  # the lineage's recordings' paths
        **ours.env_overrides, "rises.files": record["env_config"]["rises"]["files"]})
    shipped = train_config_from_dict(record["train_config"])
    # how it ran, not what it learned; the stages and milestones are the recipe's own
    machine = {"num_threads": 2, "torch_threads": None, "stages": None,
               "milestone_interval": None}
    precision = dataclasses.replace(ours.ppo, mixed_precision=shipped.ppo.mixed_precision)
    assert dataclasses.replace(ours, variant="", env_overrides={}, ppo=precision, **machine) == \
        dataclasses.replace(shipped, variant="", env_overrides={}, **machine)
    assert _plain(make_env_config(ours)) == \
        {**_plain(env_config_from_dict(record["env_config"])), "num_threads": 2}
    ours = dataclasses.replace(ours, ppo=precision)
    amended = ours
    for amendment in record["amendments"]:
        amended = amend_train_config(amended, amendment["changes"])
    assert dataclasses.replace(amended, env_overrides={}) == \
        dataclasses.replace(ours, env_overrides={})
    assert _plain(make_env_config(amended)) == _plain(make_env_config(ours))


def test_variant_settings_and_errors():
    assert set(VARIANTS) >= {"full", "recovery", "reduced"}
    assert variant_train_config("full") == variant_train_config("full", max_std=None)
    assert variant_train_config("recovery", init_std=0.3).init_std == 0.3
    with pytest.raises(KeyError, match="unknown variant 'best'"):
        variant_train_config("best")
    with pytest.raises(KeyError, match=r"unknown TrainConfig fields \['epochs'\]"):
        variant_train_config("full", epochs=3)
