"""Terrain in the batched env: each episode's ground is built where its height function
says (MuJoCo's ray casts), starts are seated on it without penetration, heights are
measured above it, the critic alone sees it, and the level follows the success rate."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import torch

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import EnvConfig, TerrainConfig
from hybrid_recovery.envs.step_state import PRIVILEGED_DIM
from hybrid_recovery.observation.actor import ACTOR_OBS_DIM

NUM_ENVS = 8


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 0
    cfg.curriculum.enabled = False
    cfg.terrain.enabled, cfg.terrain.window = True, 4
    cfg.terrain.start_level = 1.0  # the hardest tiles
    cfg.pose_weights = {"supine": 1.0, "sitting": 1.0, "standing": 1.0}
    env = RecoveryEnv(cfg)
    env._reset(np.arange(NUM_ENVS))
    env._read_state()
    env._read_state(np.arange(NUM_ENVS))
    env._obs = env._observations()
    return env


def test_a_new_run_starts_at_the_configured_level(env):
    assert env.terrain.level == 1.0 and default_config().terrain.start_level == 0.0


def test_each_episode_gets_its_own_terrain(env):
    kinds = {t.kind for t in env.terrain.terrains}
    assert len(kinds) >= 3, kinds


def test_the_ground_is_built_where_the_env_says(env):
    geom = np.array([-1], dtype=np.int32)
    points = np.random.default_rng(0).uniform(-2.5, 2.5, (NUM_ENVS, 20, 2))
    expected = env.terrain.ground(points)
    for i in range(NUM_ENVS):
        model, data = env.sims.get_model(i), env.sims.get_data(i)
        data.qpos[:3] = (100.0, 100.0, 50.0)  # the robot out of the rays' way
        mujoco.mj_kinematics(model, data)
        for (x, y), z in zip(points[i], expected[i], strict=True):
            depth = mujoco.mj_ray(model, data, np.array([x, y, 5.0]),
                                  np.array([0.0, 0.0, -1.0]), None, 1, -1, geom)
            assert 5.0 - depth == pytest.approx(z, abs=1e-6), env.terrain.terrains[i]


def test_starts_are_seated_on_the_terrain_without_penetration(env):
    for i in range(NUM_ENVS):
        model, data = env.sims.get_model(i), env.sims.get_data(i)
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        terrain = env.terrain.terrains[i]
        assert data.ncon == 0, terrain  # 5 mm above the ground
        # and not floating: exact on planes, within the bumps' height on rough ground/steps
        data.qpos[2] -= 0.006 / np.cos(np.radians(terrain.slope)) + (
            terrain.height if terrain.kind in ("rough", "step") else 0.0)
        mujoco.mj_forward(model, data)
        assert data.ncon > 0, terrain


def test_heights_are_above_the_ground_under_the_com(env):
    com = env.sims.bind("sensordata")[:, env.layout.com]
    ground = env.terrain.ground(com[:, None, :2])[:, 0]
    assert np.allclose(env._host["height"], com[:, 2] - ground)
    assert np.abs(ground).max() > 0.01  # some of them not at z = 0
    vel = env.sims.bind("sensordata")[:, env.layout.com_linvel]
    omega = np.sqrt(GRAVITY / np.maximum(com[:, 2] - ground, 1e-3))  # ξ = c + ċ/ω above it
    assert np.allclose(env._state["cp"], com[:, :2] + vel[:, :2] / omega[:, None])


def test_the_critic_alone_sees_the_terrain(env):
    obs = env.get_observations()
    grid = env.cfg.terrain.height_grid ** 2
    assert obs["policy"].shape == (NUM_ENVS, ACTOR_OBS_DIM)
    assert obs["critic"].shape == (NUM_ENVS, ACTOR_OBS_DIM + PRIVILEGED_DIM + grid)
    base = env.qpos[:, 2]
    centre = obs["critic"][:, -grid:][:, grid // 2].numpy()  # the grid's middle point
    ground = env.terrain.ground(env.qpos[:, None, :2])[:, 0]
    assert np.allclose(centre, base - ground, atol=1e-5)
    for _ in range(5):
        obs, *_ = env.step(torch.zeros(NUM_ENVS, 27))
    assert torch.isfinite(obs["critic"]).all() and env.nan_resets == 0


def test_the_level_follows_the_success_rate(env):
    tiles = env.terrain
    tiles.level, step = 0.5, env.cfg.terrain.step
    tiles.window.clear()
    tiles.record(np.array([True, True, True, False]))  # 0.75 ≥ advance 0.6
    assert tiles.level == pytest.approx(0.5 + step)
    tiles.record(np.array([False, False, False, True]))  # 0.25 < retreat 0.3
    assert tiles.level == pytest.approx(0.5)
    tiles.record(np.array([True, False, True, False]))  # 0.5: stays
    assert tiles.level == pytest.approx(0.5)


def test_without_terrain_the_scene_is_unchanged():
    cfg = default_config()
    assert not cfg.terrain.enabled
    from hybrid_recovery.sim.scene import build_scene

    plain, _ = build_scene()
    with_slots, _ = build_scene(step_height=0.1)
    assert with_slots.ngeom > plain.ngeom and plain.nhfield == 0


def test_bad_terrain_settings_are_refused_in_one_line():
    with pytest.raises(ValueError) as info:
        TerrainConfig(weights={"ice": 1.0})
    assert str(info.value) == ("terrain.weights has unknown kinds ['ice']; known: ['flat', "
                               "'slope', 'rough', 'step']")
    with pytest.raises(ValueError) as info:
        EnvConfig(terrain=TerrainConfig(enabled=True), backend="warp")
    assert str(info.value) == "terrain needs the batch backend, got 'warp'"
    with pytest.raises(ValueError) as info:
        TerrainConfig(max_slope=60.0)
    assert str(info.value) == "TerrainConfig.max_slope must be > 0 and <= 45, got 60.0"
    with pytest.raises(ValueError) as info:
        TerrainConfig(start_level=1.5)
    assert str(info.value) == "TerrainConfig.start_level must be >= 0 and <= 1, got 1.5"


def test_the_level_round_trips_through_a_checkpoint_state(env):
    tiles = env.terrain
    tiles.level = 0.7
    tiles.window.clear()
    tiles.record(np.array([True, False]))
    state = tiles.state_dict()
    tiles.level = 0.0
    tiles.window.clear()
    tiles.load_state_dict(state)
    assert tiles.level == 0.7 and tiles.window.state() == [True, False]
