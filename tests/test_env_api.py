"""RecoveryEnv: every start pose resets and steps with the declared shapes, no NaN, and
episodes that end, auto-reset and log their rewards and terminations."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.rewards import REWARD_TERMS
from hybrid_recovery.envs.terminations import TERMINATIONS
from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.sim.initial_states import POSES

NUM_ENVS = 8
EPISODE_STEPS = 12
"""Short episodes (0.24 s) so that every env times out within a test."""


def small_config(**overrides):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 3
    cfg.episode_length_s = EPISODE_STEPS * cfg.physics_dt * cfg.decimation
    cfg.curriculum.enabled = False  # final settings: every pose, full DR, pushes
    for key, value in overrides.items():
        setattr(cfg, key, value)
    return cfg


@pytest.fixture(scope="module")
def env():
    return RecoveryEnv(small_config())


def check_step(env, out) -> None:
    obs, reward, done, extras = out
    assert obs["policy"].shape == (NUM_ENVS, ACTOR_OBS_DIM) == (NUM_ENVS, 87)
    assert obs["critic"].shape == (NUM_ENVS, 104)
    assert obs["policy"].dtype == obs["critic"].dtype == torch.float32
    assert torch.isfinite(obs["policy"]).all() and torch.isfinite(obs["critic"]).all()
    assert reward.shape == (NUM_ENVS,) and torch.isfinite(reward).all()
    assert done.shape == (NUM_ENVS,) and done.dtype == torch.bool
    time_outs = extras["time_outs"]
    assert time_outs.shape == (NUM_ENVS,) and not (time_outs & ~done).any()


def run_episodes(env, pose: str, actions) -> dict:
    """Forces ``pose`` for the next resets and runs two full episodes; returns what was seen."""
    env.cfg.pose_weights = {pose: 1.0}
    seen = {"dones": 0, "timeouts": 0, "logs": [], "reset_obs": []}
    for k in range(2 * EPISODE_STEPS + 1):
        act = actions(k)
        out = env.step(act)
        check_step(env, out)
        obs, _, done, extras = out
        seen["dones"] += int(done.sum())
        seen["timeouts"] += int(extras["time_outs"].sum())
        if done.any():
            seen["logs"].append((extras["log"], done.clone(), extras["time_outs"].clone()))
            # auto-reset: the new episode's first observation has no previous action
            last_action = obs["critic"][done, 3 + 3 + 27 + 27:ACTOR_OBS_DIM]
            assert (last_action == 0).all()
            assert (env.episode_length_buf[done] == 0).all()
        else:
            assert extras["log"] == {}
    assert env.nan_resets == 0
    return seen


@pytest.mark.parametrize("pose", POSES)
def test_every_pose_resets_and_steps(env, pose):
    gen = torch.Generator().manual_seed(POSES.index(pose))
    zero = torch.zeros(NUM_ENVS, env.num_actions)
    seen = run_episodes(env, pose, lambda k: zero if k % 2 else
                        torch.rand(NUM_ENVS, env.num_actions, generator=gen) * 4 - 2)
    assert seen["dones"] >= NUM_ENVS  # every env finished at least one episode
    assert f"pose_stood_up/{pose}" in seen["logs"][-1][0]
    active = {f"reward/{name}" for name, weight_field, _ in REWARD_TERMS
              if getattr(env.cfg.rewards, weight_field) != 0.0}
    for log, done, time_outs in seen["logs"]:
        n_done = int(done.sum())
        for key in active | {f"termination/{t}" for t in TERMINATIONS}:
            assert key in log, key
            assert log[key].shape == (n_done,)
            assert torch.isfinite(log[key]).all()
        np.testing.assert_array_equal(log["termination/timeout"].numpy(),
                                      time_outs[done].numpy().astype(np.float32))
        for kind in ("success", "stood_up"):  # by start pose: a partition of the episodes
            parts = [log[f"pose_{kind}/{p}"] for p in POSES if f"pose_{kind}/{p}" in log]
            assert sum(len(v) for v in parts) == n_done
            assert sorted(torch.cat(parts).tolist()) == sorted(log[f"episode/{kind}"].tolist())
        causes = torch.stack([log[f"termination/{t}"] for t in TERMINATIONS])
        assert (causes.sum(0) >= 1).all()  # every finished episode has a cause
        assert (causes[0] + causes[1:].amax(0) <= 1).all()  # a timeout is never also a failure


def test_timeouts_come_at_the_episode_length(env):
    env.cfg.pose_weights = {"supine": 1.0}
    steps = env.episode_length_buf.clone()  # episodes of the earlier tests are under way
    for _ in range(3 * EPISODE_STEPS):
        _, _, done, extras = env.step(torch.zeros(NUM_ENVS, env.num_actions))
        steps += 1
        assert (steps[extras["time_outs"]] == EPISODE_STEPS).all()
        assert (steps[done & ~extras["time_outs"]] < EPISODE_STEPS).all()
        steps[done] = 0
    assert env.max_episode_length == EPISODE_STEPS


def test_large_actions_are_clipped_not_fatal(env):
    env.cfg.pose_weights = {"standing": 1.0}
    for sign in (1.0, -1.0):
        for _ in range(10):
            check_step(env, env.step(torch.full((NUM_ENVS, env.num_actions), 1e3 * sign)))
    assert env.nan_resets == 0


def test_reduced_critic_is_the_actor_observation():
    env = RecoveryEnv(small_config(privileged_critic=False))
    obs = env.get_observations()
    assert obs["policy"].shape == obs["critic"].shape == (NUM_ENVS, 87)
    obs, *_ = env.step(torch.zeros(NUM_ENVS, env.num_actions))
    assert obs["critic"].shape == (NUM_ENVS, 87)
    # the critic sees the clean observation, the actor the noisy one (paper §III-C, §III-G)
    noise = (obs["policy"] - obs["critic"]).abs().amax(0).numpy()
    np.testing.assert_array_less(noise, env.noise + 1e-6)
    assert noise[:3].max() > 0.1 and noise[-27:].max() == 0.0  # no noise on the last action
