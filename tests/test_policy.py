"""The one policy runner: targets as in training, checks at load, batch = rows, no torch."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import torch

from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.policy import OnnxPolicy
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.action import ACTION_CLIP, TARGET_RANGE_FACTOR, joint_targets
from hybrid_recovery.training.stand_in import write_stand_in_policy


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    return write_stand_in_policy(tmp_path_factory.mktemp("random"), "random")


def test_joint_targets_clip_then_scale():
    action = np.linspace(-25.0, 25.0, constants.NUM_JOINTS)
    expected = constants.DEFAULT_JOINT_POS + 0.3 * np.clip(action, -ACTION_CLIP, ACTION_CLIP)
    np.testing.assert_array_equal(joint_targets(action, 0.3), expected)
    batch = joint_targets(np.stack([action, -action]), 0.3)
    np.testing.assert_array_equal(batch[1], joint_targets(-action, 0.3))
    lo, hi = expected - 0.1, expected - 0.05  # below every unclamped target
    np.testing.assert_array_equal(joint_targets(action, 0.3, (lo, hi)), hi)


def test_directory_or_file_with_its_description_and_batch_equals_rows(export):
    from_dir, from_file = OnnxPolicy(export), OnnxPolicy(export / "policy.onnx")
    assert from_dir.path == from_file.path == export / "policy.onnx"
    assert from_dir.description == json.loads((export / "policy.json").read_text())
    assert from_dir.action_scale == 0.3
    obs = np.random.default_rng(0).normal(size=(3, ACTOR_OBS_DIM))
    batch = from_dir.act(obs)
    assert batch.shape == (3, constants.NUM_JOINTS) and batch.dtype == np.float64
    for row, o in zip(batch, obs, strict=True):
        np.testing.assert_array_equal(row, from_file(o))
    assert np.abs(batch).max() > 0.0


def test_description_is_checked_when_present_or_required(export, tmp_path):
    (tmp_path / "policy.onnx").write_bytes((export / "policy.onnx").read_bytes())
    assert OnnxPolicy(tmp_path).description is None
    with pytest.raises(FileNotFoundError) as info:
        OnnxPolicy(tmp_path, require_description=True)
    assert str(info.value) == f"policy description not found: {tmp_path / 'policy.json'}"
    desc = json.loads((export / "policy.json").read_text())
    desc["kd"][0] += 1.0
    (tmp_path / "policy.json").write_text(json.dumps(desc))
    with pytest.raises(ValueError) as info:
        OnnxPolicy(tmp_path)
    assert str(info.value) == f"{tmp_path / 'policy.json'} kd differs from the robot constants"


def test_described_graph_must_declare_the_actions(export, tmp_path):
    torch.onnx.export(torch.nn.Linear(ACTOR_OBS_DIM, 5), (torch.zeros(1, ACTOR_OBS_DIM),),
                      str(tmp_path / "policy.onnx"), input_names=["obs"],
                      output_names=["actions"], dynamo=False)
    assert OnnxPolicy(tmp_path).description is None  # bare: checked per call
    (tmp_path / "policy.json").write_text((export / "policy.json").read_text())
    with pytest.raises(ValueError) as info:
        OnnxPolicy(tmp_path)
    assert str(info.value) == "policy.onnx returns [1, 5], expected [1, 27]"


def test_deploy_runner_and_envs_package_load_without_torch(export):
    code = ("import sys\n"
            "from hybrid_recovery.deploy.policy_runner import PolicyRunner\n"
            "import hybrid_recovery.envs\n"
            f"PolicyRunner({str(export)!r})\n"
            "print('torch' in sys.modules)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "False"


def test_the_shipped_policy_is_complete_and_runs():
    from hybrid_recovery.policy import SHIPPED_POLICY, is_shipped, resolve_policy

    assert is_shipped(), f"no policy.onnx in {SHIPPED_POLICY}"
    assert resolve_policy("shipped") == SHIPPED_POLICY
    size = sum(f.stat().st_size for f in SHIPPED_POLICY.iterdir())
    assert size < 5e6, f"the shipped policy takes {size / 1e6:.1f} MB"
    record = json.loads((SHIPPED_POLICY / "training_record.json").read_text())
    for key in ("git_commit", "env_steps", "compute_time_s", "hardware", "train_config",
                "env_config"):
        assert record[key], key
    assert (SHIPPED_POLICY / "curves.png").stat().st_size > 10_000
    policy = OnnxPolicy(SHIPPED_POLICY)  # checks policy.json against this robot
    action = policy.act(np.zeros((2, ACTOR_OBS_DIM)))
    assert action.shape == (2, constants.NUM_JOINTS) and np.isfinite(action).all()


def test_learned_controller_is_the_shipped_policy_and_says_when_there_is_none(monkeypatch,
                                                                               tmp_path):
    from hybrid_recovery.controllers import make
    from hybrid_recovery.policy import SHIPPED_POLICY, shipped

    assert make("learned").policy.path == SHIPPED_POLICY / "policy.onnx"
    monkeypatch.setattr(shipped, "SHIPPED_POLICY", tmp_path)
    with pytest.raises(ValueError, match="no policy is shipped"):
        make("learned")
    with pytest.raises(FileNotFoundError, match="no policy is shipped"):
        shipped.resolve_policy("shipped")


def _saturating(controller) -> None:
    """Makes a controller's policy ask for a = +ACTION_CLIP on every joint."""
    controller.policy = lambda obs: np.full(constants.NUM_JOINTS, ACTION_CLIP)


@pytest.mark.parametrize("kind", ["position", "torque"])
def test_controllers_clamp_targets_as_training_and_the_robot_do(export, kind):
    """q* + 0.3 · 10 is beyond most joint ranges: the targets stop at the ranges scaled
    about their middle by the policy's factor (0.9), as the training env's and the
    safety layer's do."""
    import mujoco

    from hybrid_recovery.control.policy_controller import PolicyController
    from hybrid_recovery.controllers import OnnxPolicyController
    from hybrid_recovery.deploy.state_machine import SafetyConfig
    from hybrid_recovery.envs.config import CurriculumConfig
    from hybrid_recovery.robot.limits import SafetyLimits
    from hybrid_recovery.robot.mjcf import load_mjmodel

    policy = OnnxPolicy(export)
    assert policy.target_range_factor == TARGET_RANGE_FACTOR == 0.9
    assert CurriculumConfig().position_limit_final == SafetyConfig.q_ref_range_factor == 0.9
    model = load_mjmodel(None)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    if kind == "position":
        controller = OnnxPolicyController(export, delay=0.0)
        controller.reset(model, data)
        _saturating(controller)
        target = controller(model, data)
    else:
        controller = PolicyController(policy)
        controller.reset(model, data)
        _saturating(controller)
        target = controller.update_targets(model, data)
    limits = SafetyLimits.from_model(model)
    lo, hi = limits.q_ref_bounds(0.9)
    unclamped = joint_targets(np.full(constants.NUM_JOINTS, ACTION_CLIP), 0.3)
    np.testing.assert_allclose(target, np.minimum(unclamped, hi))
    assert (target < limits.q_max).all() and (target < unclamped).sum() >= 20


def test_a_description_without_the_factor_means_the_default(export, tmp_path):
    import shutil

    desc = json.loads((export / "policy.json").read_text())
    desc["action"]["target_range_factor"] = 0.8
    other = tmp_path / "other"
    shutil.copytree(export, other)
    (other / "policy.json").write_text(json.dumps(desc))
    assert OnnxPolicy(other).target_range_factor == 0.8
    del desc["action"]["target_range_factor"]  # descriptions written before it was kept
    (other / "policy.json").write_text(json.dumps(desc))
    assert OnnxPolicy(other).target_range_factor == TARGET_RANGE_FACTOR
