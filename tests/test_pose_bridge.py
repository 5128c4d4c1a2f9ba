"""Start-pose bridge: blends of two poses, the level's advance, bridged resets, and its
state across a resumed run."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import BridgeConfig
from hybrid_recovery.envs.pose_bridge import PoseBridge, blend_pose
from hybrid_recovery.sim.initial_states import POSE_LIBRARY, POSES
from hybrid_recovery.training.checkpoint import atomic_save, load_checkpoint
from hybrid_recovery.training.config import TrainConfig
from hybrid_recovery.training.runner import train

HIP_PITCH = [1, 7]
"""Left and right hip pitch among the 27 joints."""


def test_off_by_default():
    assert default_config().bridge.levels == 0
    bridge = PoseBridge(BridgeConfig())
    assert bridge.targets == () and not bridge.active("kneeling")
    assert bridge.blend("kneeling") == 1.0 and bridge.poses() == {}


def test_blends_run_from_the_source_to_the_target():
    src, dst = POSE_LIBRARY["half_kneeling"], POSE_LIBRARY["kneeling"]
    np.testing.assert_array_equal(blend_pose(src, dst, 0.0).joints, src.joints)
    np.testing.assert_allclose(blend_pose(src, dst, 1.0).joints, dst.joints)
    mid = blend_pose(src, dst, 0.25)
    np.testing.assert_allclose(mid.joints, 0.75 * src.joints + 0.25 * dst.joints)
    assert mid.mirrored and mid.settle_time == min(src.settle_time, dst.settle_time)
    with pytest.raises(ValueError, match="blend fraction"):
        blend_pose(src, dst, 1.5)
    poses = PoseBridge(BridgeConfig(levels=4, pairs=(("half_kneeling", "kneeling"),
                                                     ("squatting", "sitting")))).poses()
    assert list(poses) == [f"{t}@{k}/4" for t in ("kneeling", "sitting") for k in range(4)]
    np.testing.assert_allclose(poses["kneeling@2/4"].joints, (src.joints + dst.joints) / 2)
    squat, sit = POSE_LIBRARY["squatting"], POSE_LIBRARY["sitting"]
    assert poses["sitting@1/4"].pitch == pytest.approx(0.75 * squat.pitch + 0.25 * sit.pitch)


TWO = (("half_kneeling", "kneeling"), ("squatting", "sitting"))


def test_a_level_is_earned_by_the_stand_up_rate_of_a_full_window():
    bridge = PoseBridge(BridgeConfig(levels=2, advance=0.5, window=4))
    assert not bridge.record("kneeling", np.array([True, True, True]))  # window not full
    assert bridge.level["kneeling"] == 0
    assert bridge.record("kneeling", np.array([False]))                 # 3 of 4 ≥ 0.5
    assert bridge.level["kneeling"] == 1
    bridge = PoseBridge(BridgeConfig(levels=2, advance=0.5, window=4))
    bridge.record("kneeling", np.array([False, False, False, True]))   # 0.25 < 0.5
    assert bridge.level["kneeling"] == 0
    assert bridge.record("kneeling", np.array([True, True]))       # last 4: F T T T
    assert bridge.blend("kneeling") == 0.5 and bridge.pool_name("kneeling") == "kneeling@1/2"
    assert not bridge.record("kneeling", np.array([True] * 3))     # the window starts afresh
    assert bridge.record("kneeling", np.array([True]))
    assert not bridge.active("kneeling") and bridge.blend("kneeling") == 1.0
    assert not bridge.record("kneeling", np.array([True] * 8))     # done: stays at the target
    assert not bridge.record("sitting", np.array([True] * 8))      # not a bridged pose


def test_a_bridge_steps_back_below_the_retreat_rate_but_not_below_the_source():
    bridge = PoseBridge(BridgeConfig(levels=4, advance=0.5, retreat=0.2, window=4))
    assert bridge.record("kneeling", np.array([False] * 4)) == 0  # already at the source
    bridge.level["kneeling"] = 2
    assert bridge.record("kneeling", np.array([True, False, False, False])) == 0  # 0.25
    assert bridge.record("kneeling", np.array([False])) == -1     # last 4: 0.0 < 0.2
    assert bridge.level["kneeling"] == 1
    assert bridge.record("kneeling", np.array([True, True, False, False])) == 1
    assert bridge.level["kneeling"] == 2


def test_a_state_saved_with_other_levels_keeps_its_blend():
    eight = PoseBridge(BridgeConfig(levels=8, pairs=TWO))
    eight.level.update(kneeling=3, sitting=8)
    sixteen = PoseBridge(BridgeConfig(levels=16, pairs=TWO))
    sixteen.load_state_dict(eight.state_dict())
    assert sixteen.level == {"kneeling": 6, "sitting": 16}
    assert sixteen.blend("kneeling") == eight.blend("kneeling") == 0.375
    four = PoseBridge(BridgeConfig(levels=4, pairs=TWO))
    four.load_state_dict(eight.state_dict())
    assert four.level == {"kneeling": 1, "sitting": 4}  # at or below 3/8


def test_bridges_advance_apart_and_their_levels_are_restored():
    bridge = PoseBridge(BridgeConfig(levels=3, advance=0.5, window=2, pairs=TWO))
    bridge.record("sitting", np.array([True, True]))
    bridge.record("kneeling", np.array([True, False, False]))
    assert bridge.level == {"kneeling": 0, "sitting": 1}
    other = PoseBridge(BridgeConfig(levels=3, advance=0.5, window=2, pairs=TWO))
    other.load_state_dict(bridge.state_dict())
    assert other.level == bridge.level
    assert other.record("kneeling", np.array([True]))  # its window came along: F T
    old = PoseBridge(BridgeConfig(levels=3, pairs=TWO))
    old.load_state_dict({"level": 2, "outcomes": [True]})  # one bridge's saved state
    assert old.level == {"kneeling": 2, "sitting": 0}


def test_only_starts_at_the_current_level_count():
    bridge = PoseBridge(BridgeConfig(levels=8, advance=0.5, window=4))
    bridge.level["kneeling"] = 4
    # rises from lower levels earn nothing: 4 of the current level's are needed
    assert not bridge.record("kneeling", np.ones(6, bool), np.array([0, 1, 2, 3, 4, 4]))
    assert bridge.record("kneeling", np.ones(3, bool), np.array([4, 4, 3]))
    assert bridge.level["kneeling"] == 5


@pytest.mark.parametrize("bad", [{"pairs": (("crouching", "kneeling"),)},
                                 {"pairs": (("squatting", "lying"),)},
                                 {"pairs": (("kneeling", "kneeling"),)},
                                 {"pairs": (("squatting", "sitting"), ("supine", "sitting"))},
                                 {"pairs": (("squatting",),)},
                                 {"levels": -1}, {"window": 0}, {"advance": 0.0},
                                 {"retreat": 0.3}, {"retreat": -0.1}])
def test_bad_settings_are_refused(bad):
    with pytest.raises(ValueError, match="bridge|BridgeConfig"):  # the numbers: at construction
        PoseBridge(BridgeConfig(**bad))


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 16, 1, 3
    cfg.curriculum.enabled = False
    cfg.pose_weights = {"kneeling": 1.0}
    cfg.bridge = BridgeConfig(levels=2, advance=0.5, window=16, pairs=TWO)
    return RecoveryEnv(cfg)


def _front_hip(env: RecoveryEnv) -> np.ndarray:
    """The more flexed hip pitch of each env's start [rad]."""
    return env.qpos[:, env.qadr[HIP_PITCH]].min(1)


def test_the_targets_episodes_start_from_the_current_blend(env):
    ids = np.arange(env.num_envs)
    env.bridge.level["kneeling"] = 0  # the half-kneel: one hip flexed to ≈ −1.5 rad
    env._reset(ids)
    assert (env.start_pose == POSES.index("kneeling")).all()
    assert (_front_hip(env) < -1.1).all()
    env.bridge.level["kneeling"] = 1  # half way (−0.8 rad held by PD; settled, the knee's load has
    env._reset(ids)       # pushed it back to −0.55 ± 0.05 rad, ±0.1 start noise)
    assert ((_front_hip(env) > -1.1) & (_front_hip(env) < -0.2)).all()
    env.bridge.level["kneeling"] = 2  # the kneel itself: both hips near −0.1 rad
    env._reset(ids)
    assert (_front_hip(env) > -0.6).all()
    assert set(env.bridge_pool) == {"kneeling@0/2", "kneeling@1/2", "sitting@0/2",
                                    "sitting@1/2"}


def test_finished_target_episodes_advance_the_bridge(env):
    env.bridge.load_state_dict({"level": {"kneeling": 0, "sitting": 0}})
    ids = np.arange(env.num_envs)
    env._reset(ids)  # every start is a kneel
    dones = {name: np.zeros(env.num_envs, bool) for name in
             ("torso_contact", "stuck_low", "nan", "timeout")}
    env.stood_up[:] = True
    log = env._episode_log(ids, dones)
    assert env.bridge.level == {"kneeling": 1, "sitting": 0}
    assert log["bridge_blend/kneeling"] == 0.5 and log["bridge_blend/sitting"] == 0.0
    env.stood_up[:] = False
    env._episode_log(ids, dones)
    assert env.bridge.level["kneeling"] == 1


def test_the_bridge_level_is_checkpointed_and_resumed(tmp_path):
    run = tmp_path / "run"
    overrides = {"curriculum.window": 8, "curriculum.advance_success": 0.0,
                 "bridge.levels": 3, "bridge.advance": 1.0, "bridge.window": 100000}
    cfg = TrainConfig(num_envs=8, iterations=2, save_interval=1, num_threads=1,
                      env_overrides=overrides)
    train(run, cfg)
    data = load_checkpoint(run / "latest.pt")
    assert data["infos"]["bridge"]["level"] == {"kneeling": 0}
    data["infos"]["bridge"] = {"level": {"kneeling": 2}, "outcomes": {"kneeling": [True]}}
    atomic_save(data, run / "latest.pt")
    cfg.iterations = 3
    resumed = train(run, cfg, resume=True)
    assert resumed.env.bridge.level == {"kneeling": 2}  # none can be earned: the saved one
    assert load_checkpoint(run / "latest.pt")["infos"]["bridge"]["level"] == {"kneeling": 2}
