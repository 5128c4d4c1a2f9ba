"""Initial states (paper §III-F–§III-G): settled pool states and perturbed, re-seated episode starts
are physically valid (no penetration of the ground) with plausible CoM heights.

CoM heights [m] of the project's H1-2 (h* = 0.92 m standing):

=========  ============  ===================================================
pose       settled pool  episode start (±0.2 rad base tilt, ±0.1 rad joints)
=========  ============  ===================================================
standing   0.88 – 0.95   0.85 – 1.00
squatting  0.48 – 0.62   0.45 – 0.70
kneeling   0.30 – 0.60   0.28 – 0.68
sitting    0.15 – 0.30   0.15 – 0.40
supine     0.07 – 0.13   0.07 – 0.40 (a tilted lying body is lifted at one end)
prone      0.07 – 0.14   0.07 – 0.40
half_kn.   0.50 – 0.62   0.45 – 0.70 (beyond the paper)
=========  ============  ===================================================
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.sim.initial_states import POSES, robot_geoms

NUM_ENVS = 16
POOL_COM = {"standing": (0.88, 0.95), "squatting": (0.48, 0.62), "kneeling": (0.30, 0.60),
            "sitting": (0.15, 0.30), "supine": (0.07, 0.13), "prone": (0.07, 0.14),
            "half_kneeling": (0.50, 0.62)}
START_COM = {"standing": (0.85, 1.00), "squatting": (0.45, 0.70), "kneeling": (0.28, 0.68),
             "sitting": (0.15, 0.40), "supine": (0.07, 0.40), "prone": (0.07, 0.40),
             "half_kneeling": (0.45, 0.70)}
SETTLED_PENETRATION = 0.010
"""Deepest ground penetration of a settled state [m] (soft contact under the robot's
weight; measured ≤ 8.2 mm standing, which settles only 0.2 s, median ≤ 2.4 mm)."""


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 7
    cfg.curriculum.enabled = False
    return RecoveryEnv(cfg)


def floor_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Signed distances [m] of the robot–floor contacts after mj_forward (negative: inside)."""
    mujoco.mj_forward(model, data)
    return np.array([c.dist for c in data.contact[:data.ncon]])


@pytest.mark.parametrize("pose", POSES)
def test_settled_pool_states(env, pose):
    qpos, qvel = env.pool[pose]
    assert qpos.shape == (32, env.model.nq) and np.isfinite(qpos).all()
    data = mujoco.MjData(env.model)
    heights = []
    for q in qpos:
        data.qpos[:], data.qvel[:] = q, 0.0
        dist = floor_contacts(env.model, data)
        assert len(dist) > 0, "a settled state rests on the ground"
        assert dist.min() > -SETTLED_PENETRATION
        heights.append(data.subtree_com[1, 2])
    lo, hi = POOL_COM[pose]
    assert lo <= min(heights) and max(heights) <= hi, (min(heights), max(heights))


@pytest.mark.parametrize("pose", POSES)
def test_episode_starts_are_seated_on_the_ground(env, pose):
    """After the reset noise the lowest geom is 5 mm above the ground: no contact, and one
    as soon as the robot is lowered by 6 mm."""
    env.cfg.pose_weights = {pose: 1.0}
    ids = np.arange(NUM_ENVS)
    env._reset(ids)
    env._read_state(ids)
    # inside this episode's joint ranges (0.9× at the final stage): no limit kick at t = 0
    q_lo, q_hi = env.randomizer.jnt_range[:, 1:28].transpose(2, 0, 1)
    q = env.qpos[:, env.qadr]
    assert ((q >= q_lo) & (q <= q_hi)).all()
    lo, hi = START_COM[pose]
    heights = env._state["height"]
    assert (heights >= lo).all() and (heights <= hi).all(), (heights.min(), heights.max())
    geoms = set(robot_geoms(env.model).tolist())
    for i in ids:
        model, data = env.sims.get_model(i), env.sims.get_data(i)
        assert len(floor_contacts(model, data)) == 0
        data.qpos[2] -= 0.006
        dist = floor_contacts(model, data)
        assert len(dist) > 0 and dist.min() > -0.0011
        touching = {c.geom1 for c in data.contact[:data.ncon]} | \
            {c.geom2 for c in data.contact[:data.ncon]}
        assert touching & geoms


def test_start_poses_are_different_after_the_noise(env):
    env.cfg.pose_weights = {"standing": 1.0}
    ids = np.arange(NUM_ENVS)
    env._reset(ids)
    joints = env.qpos[:, env.qadr]
    assert joints.std(0).min() > 0.01  # joint offsets per episode
    yaw = np.arctan2(2 * (env.qpos[:, 3] * env.qpos[:, 6] + env.qpos[:, 4] * env.qpos[:, 5]),
                     1 - 2 * (env.qpos[:, 5] ** 2 + env.qpos[:, 6] ** 2))
    assert np.ptp(yaw) > 1.0  # random heading
    np.testing.assert_allclose(np.linalg.norm(env.qpos[:, 3:7], axis=1), 1.0, atol=1e-12)


def test_the_half_kneel_pool_has_either_foot_in_front(env):
    """Half of the half-kneel pool is the mirror image: left foot forward, then right."""
    qpos, _ = env.pool["half_kneeling"]
    hip_pitch = qpos[:, env.qadr[[1, 7]]]  # left, right
    front_left = hip_pitch[:, 0] < hip_pitch[:, 1] - 1.0
    np.testing.assert_array_equal(front_left, np.arange(len(qpos)) < len(qpos) // 2)


def test_the_half_kneel_is_off_by_default():
    assert default_config().pose_weights["half_kneeling"] == 0.0
