"""One policy step for every runner: o_t → π → clip → q_ref."""

from __future__ import annotations

import numpy as np

from hybrid_recovery.observation import actor_observation
from hybrid_recovery.policy import policy_step
from hybrid_recovery.robot.action import ACTION_CLIP
from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS, NUM_JOINTS


def test_the_step_feeds_the_shared_observation_and_clips_before_the_targets():
    rng = np.random.default_rng(0)
    gyro, quat = rng.normal(size=3), np.array([0.9, 0.1, 0.3, 0.0])
    q, dq, last = rng.normal(size=NUM_JOINTS), rng.normal(size=NUM_JOINTS), np.ones(NUM_JOINTS)
    seen = []

    def policy(obs: np.ndarray) -> np.ndarray:
        seen.append(obs)
        return np.linspace(-3 * ACTION_CLIP, 3 * ACTION_CLIP, NUM_JOINTS)

    step = policy_step(policy, gyro, quat, q, dq, last, scale=0.3)
    want = actor_observation(gyro[None], quat[None], q[None], dq[None], last[None])[0]
    np.testing.assert_array_equal(seen[0], want)
    np.testing.assert_array_equal(step.obs, want)
    np.testing.assert_array_equal(step.action, policy(want))  # the raw output is kept
    assert np.abs(step.last_action).max() == ACTION_CLIP
    np.testing.assert_allclose(step.q_ref, DEFAULT_JOINT_POS + 0.3 * step.last_action)
    bounds = (DEFAULT_JOINT_POS - 0.1, DEFAULT_JOINT_POS + 0.1)
    clamped = policy_step(policy, gyro, quat, q, dq, last, 0.3, bounds).q_ref
    np.testing.assert_allclose(clamped, np.clip(step.q_ref, *bounds))
    assert np.isclose(np.abs(clamped - DEFAULT_JOINT_POS).max(), 0.1)


def test_the_step_is_written_once():
    """Outside their own modules, the observation builder and the action mapping are called
    only by :func:`policy_step`, by the batched environment (which gets its actions from
    the training runner, not from a policy it runs), by the training's teacher (which
    builds the observations of recorded states, running no policy) and by the terms bench
    (which times the environment's terms)."""
    import ast
    from pathlib import Path

    package = Path(__file__).resolve().parents[1] / "hybrid_recovery"
    own = {"observation/actor.py", "robot/action.py"}
    callers = set()
    for path in package.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call):
                name = getattr(node.func, "id", getattr(node.func, "attr", None))
                if name in ("actor_observation", "joint_targets", "clip_action"):
                    callers.add(path.relative_to(package).as_posix())
    assert callers - own == {"policy/step.py", "envs/recovery_env.py", "training/teacher.py",
                             "bench/terms.py"}
