"""The ONNX runner against the training-time policy, and its refusals.

A policy is trained for one PPO iteration on 8 envs and exported; then, in closed loop
with the training environment, the runner's observation (built from the robot-side state
through :class:`LowStateReading`) must equal the environment's clean observation, and its
onnxruntime action the torch actor's action on that observation.
"""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from hybrid_recovery.deploy.policy_runner import ACTION_CLIP, PolicyMismatchError, PolicyRunner
from hybrid_recovery.deploy.robot_io import LowStateReading
from hybrid_recovery.envs import RecoveryEnv
from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.robot import constants
from hybrid_recovery.training import TrainConfig, load_checkpoint, train
from hybrid_recovery.training.export import actor_from_checkpoint, export_policy
from hybrid_recovery.training.runner import make_env_config
from hybrid_recovery.training.stand_in import write_stand_in_policy

FAST = {"curriculum.window": 8, "curriculum.advance_success": 0.0}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    cfg = TrainConfig(num_envs=8, iterations=1, save_interval=1, num_threads=1,
                      env_overrides=dict(FAST))
    train(run, cfg)
    return run, export_policy(run, run / "export"), cfg


def _robot_state(env: RecoveryEnv, i: int, tick: int) -> LowStateReading:
    """What the robot would report for env ``i``: torso IMU sensors and joint encoders."""
    sd = env.sims.bind("sensordata")[i]
    return LowStateReading(tick=tick, quat=sd[env.layout.quat].copy(),
                           gyro=sd[env.layout.gyro].copy(), q=env.qpos[i, env.qadr].copy(),
                           dq=env.qvel[i, env.dadr].copy(),
                           tau_est=np.zeros(constants.NUM_JOINTS))


def test_runner_matches_the_training_policy_in_closed_loop(exported):
    run, export, cfg = exported
    runner = PolicyRunner(export)
    actor = actor_from_checkpoint(load_checkpoint(run / "latest.pt"))
    env_cfg = make_env_config(cfg)
    env_cfg.num_envs = 2
    env = RecoveryEnv(env_cfg)
    runner.reset()
    moved = 0.0
    for k in range(15):
        out = runner.step(_robot_state(env, 0, k))
        clean = env.get_observations()["critic"][0, :ACTOR_OBS_DIM].numpy()
        np.testing.assert_allclose(out.obs, clean, atol=1e-6)
        with torch.no_grad():
            expected = actor(TensorDict({"policy": torch.from_numpy(clean)[None]},
                                        batch_size=[1]), stochastic_output=False)[0].numpy()
        np.testing.assert_allclose(out.action, expected, atol=1e-5)
        np.testing.assert_allclose(out.q_ref, constants.DEFAULT_JOINT_POS + runner.action_scale
                                   * np.clip(out.action, -ACTION_CLIP, ACTION_CLIP))
        actions = torch.zeros(2, constants.NUM_JOINTS)
        actions[0] = torch.from_numpy(out.action.astype(np.float32))
        moved += float(np.abs(out.obs[6:33]).sum())
        _, _, dones, _ = env.step(actions)
        assert not dones[0], "env 0 ended its episode; the comparison needs one episode"
    assert moved > 0.0


def _copy_export(export, tmp_path):
    out = tmp_path / "policy"
    shutil.copytree(export, out)
    return out


def test_policy_json_mismatch_is_refused_with_the_reason(exported, tmp_path):
    _, export, _ = exported
    out = _copy_export(export, tmp_path)
    desc = json.loads((out / "policy.json").read_text())
    desc["kp"][3] += 50.0
    (out / "policy.json").write_text(json.dumps(desc))
    with pytest.raises(PolicyMismatchError) as err:
        PolicyRunner(out)
    assert str(err.value) == (f"refusing policy {out}: {out / 'policy.json'} kp differs from "
                              "the robot constants")


def test_other_control_period_and_effort_limits_are_refused(exported, tmp_path):
    _, export, _ = exported
    out = _copy_export(export, tmp_path)
    desc = json.loads((out / "policy.json").read_text())
    desc["control_period_s"] = 0.04
    (out / "policy.json").write_text(json.dumps(desc))
    with pytest.raises(PolicyMismatchError) as err:
        PolicyRunner(out)
    assert str(err.value) == (f"refusing policy {out}: it was trained at a control period of "
                              "0.04 s, this runner runs at 0.02 s")
    desc["control_period_s"] = 0.02
    desc["effort_limits"][0] = 500.0
    (out / "policy.json").write_text(json.dumps(desc))
    with pytest.raises(PolicyMismatchError, match="effort_limits differ from the robot constants"):
        PolicyRunner(out)
    desc["effort_limits"][0] = constants.EFFORT_LIMITS[0]
    desc["action"]["target_range_factor"] = 0.8
    (out / "policy.json").write_text(json.dumps(desc))
    with pytest.raises(PolicyMismatchError, match=r"joint ranges × 0.8 in training, the "
                                                  r"safety layer clamps them to × 0.9"):
        PolicyRunner(out)
    assert PolicyRunner(out, target_range_factor=0.8).policy.target_range_factor == 0.8


def test_missing_files_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="policy description not found"):
        PolicyRunner(tmp_path)


def test_zero_stand_in_commands_the_default_pose(tmp_path):
    runner = PolicyRunner(write_stand_in_policy(tmp_path / "zero", "zero"))
    state = LowStateReading(tick=0, quat=np.array([0.9, 0.1, 0.3, 0.0]), gyro=np.ones(3),
                            q=np.full(constants.NUM_JOINTS, 0.3),
                            dq=np.ones(constants.NUM_JOINTS),
                            tau_est=np.zeros(constants.NUM_JOINTS))
    out = runner.step(state)
    np.testing.assert_array_equal(out.action, 0.0)
    np.testing.assert_array_equal(out.q_ref, constants.DEFAULT_JOINT_POS)
