"""Start-state replay: sampling along episodes, harvesting rises, replayed resets."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import ReplayConfig
from hybrid_recovery.envs.replay import StartReplay
from hybrid_recovery.sim.initial_states import POSES

NQ, NV = 3, 2


def _replay(**cfg) -> StartReplay:
    return StartReplay(ReplayConfig(**{"fraction": 0.5, "interval_s": 0.04, **cfg}),
                       num_envs=2, nq=NQ, nv=NV, episode_steps=10, dt=0.02)


def _feed(r: StartReplay, steps: int, heights: np.ndarray) -> None:
    """Runs ``steps`` control steps; env e's state at step t is (t, e) everywhere."""
    for t in range(steps):
        state = np.array([[t, 0.0], [t, 1.0]])
        r.record(np.full(2, t), np.repeat(state, [2, 1], 1), state, heights[t],
                 np.array([True, True]))


def test_off_by_default():
    cfg = default_config()
    assert cfg.replay.fraction == 0.0
    env_cfg = default_config()
    env_cfg.num_envs, env_cfg.num_threads = 4, 1
    env = RecoveryEnv(env_cfg)
    env.step(torch.zeros(4, env.num_actions))
    assert not env.replay.active and not env.replayed.any()
    assert not env.replay.draw(100, np.random.default_rng(0)).any()


def test_samples_every_interval_and_harvests_only_the_low_ones():
    r = _replay()  # every 2 control steps
    heights = np.array([[0.3, 0.3], [0.3, 0.3], [0.5, 0.5], [0.5, 0.5], [0.9, 0.9]])
    _feed(r, 5, heights)  # samples at t = 0, 2, 4 (heights 0.3, 0.5, 0.9)
    assert r.size == 0 and not r.draw(10, np.random.default_rng(0)).any()  # nothing yet
    added = r.harvest(np.array([1]), np.array([4]), upright_height=0.85)
    assert added == 2 and r.size == 2
    np.testing.assert_array_equal(r.qvel[:2], [[0, 1], [2, 1]])  # env 1 at t = 0 and 2
    np.testing.assert_array_equal(r.qpos[:2, 2], [1, 1])
    np.testing.assert_array_equal(r.pose[:2], [4, 4])
    assert r.harvest(np.array([1]), np.array([4]), 0.85) == 0  # harvested once
    qpos, qvel, pose = r.sample(50, np.random.default_rng(0))
    assert set(qvel[:, 0]) == {0.0, 2.0} and (pose == 4).all() and qpos.shape == (50, NQ)


def test_the_buffer_is_a_ring():
    r = _replay(capacity=3)
    _feed(r, 8, np.full((8, 2), 0.2))  # 4 samples each
    assert r.harvest(np.array([0, 1]), np.array([2, 3]), 0.85) == 8
    assert r.size == 3
    np.testing.assert_array_equal(np.sort(r.qvel[:, 0]), [2, 4, 6])  # env 1's last three
    assert (r.qvel[:, 1] == 1).all() and (r.pose == 3).all()


@pytest.mark.parametrize("cfg", [{"fraction": 1.5}, {"capacity": 0}, {"interval_s": 0.0}])
def test_bad_settings_are_refused(cfg):
    with pytest.raises(ValueError, match="replay"):
        _replay(**cfg)


def test_unknown_replay_poses_are_refused():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.replay.poses = 2, 1, ("kneeling", "crouching")
    with pytest.raises(ValueError, match="replay.poses"):
        RecoveryEnv(cfg)


def _standing_env(**replay) -> RecoveryEnv:
    cfg = default_config()
    cfg.num_envs, cfg.num_threads = 8, 1
    cfg.pose_weights = {p: float(p == "standing") for p in cfg.pose_weights}
    cfg.curriculum.stage1_poses = ["standing"]
    cfg.curriculum.window = 8
    for key, value in {"fraction": 1.0, "interval_s": 0.02, **replay}.items():
        setattr(cfg.replay, key, value)
    return RecoveryEnv(cfg)


def test_a_rise_enters_the_buffer_with_its_low_samples():
    env = _standing_env()
    n = env.num_envs
    low = np.full(n, 0.5)
    fake_qpos = env.qpos.copy()
    fake_qpos[:, 2] = 0.4  # a state "from before the rise", marked by its base height
    env.replay.record(np.zeros(n, int), fake_qpos, env.qvel.copy(), low, np.ones(n, bool))
    env.up_time[:] = 0.99  # standing still: up for 1 s after this step
    env.step(torch.zeros(n, env.num_actions))
    assert env.stood_up.all()
    assert env.replay.size == n  # the low sample of each; the real (standing) one is high
    np.testing.assert_allclose(env.replay.qpos[:n, 2], 0.4)
    assert (env.replay.pose[:n] == POSES.index("standing")).all()


def test_replayed_resets_start_from_buffered_states_unassisted_and_count_apart():
    env = _standing_env(poses=("standing",))
    env.cfg.assist.fraction = 0.5  # assistance for every episode but the replayed ones
    env.assist.fraction = 0.5
    n, supine = env.num_envs, POSES.index("supine")
    state = env.pool["supine"]
    env.replay.record(np.zeros(n, int), state[0][:n], np.full((n, env.model.nv), 0.1),
                      np.full(n, 0.2), np.ones(n, bool))
    env.replay.harvest(np.arange(n), np.full(n, supine), env.cfg.upright_height)
    ids = np.arange(n)
    env._reset(ids)
    env._read_state(ids)
    assert env.replayed.all() and (env.start_pose == supine).all()
    np.testing.assert_allclose(env.qvel, 0.1)  # moving, as recorded
    first = state[0][:n]
    matched = [np.flatnonzero(np.all(np.isclose(first[:, 3:], q[3:]), 1)) for q in env.qpos]
    assert all(len(m) for m in matched)  # each start is a buffered state (seated: z moves)
    dz = [abs(env.qpos[i, 2] - first[m[0], 2]) for i, m in enumerate(matched)]
    assert max(dz) < 0.02
    assert not env._recording().any()  # a replayed rise is not recorded again
    env.step(torch.zeros(n, env.num_actions))
    pushes = env.pushes.force(env.upright_time, env.rng, env.curriculum.difficulty)
    np.testing.assert_allclose(env.xfrc[:, env.torso, 2], pushes[:, 2])  # no pull
    env.stood_up[:] = True
    log = env._episode_log(ids, {name: np.zeros(n, bool) for name in ("timeout",
                                                                     "torso_contact",
                                                                     "stuck_low", "nan")})
    assert log["replay/stood_up"].numel() == n and log["replay_stood_up/supine"].numel() == n
    assert "pose_stood_up/supine" not in log and log["replay/buffer_size"] == n
    assert len(env.curriculum._outcomes) == 0 and len(env.assist._outcomes) == 0
    assert env.assist.active and env.assist.force_z(np.ones(1), np.array([[0, 0, -1.0]]),
                                                    GRAVITY)[0] > 0  # the pull is on
