"""A 3-iteration rsl-rl PPO run on 16 envs with the asymmetric observation groups, and its
policy exported to ONNX and run the way ``hybrid-recovery play --policy`` runs it."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from hybrid_recovery.training import TrainConfig, load_checkpoint, train


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("run")
    threads = torch.get_num_threads()
    try:
        cfg = TrainConfig(num_envs=16, iterations=3, save_interval=1, num_threads=1)
        runner = train(run_dir, cfg)
    finally:
        torch.set_num_threads(threads)
    return run_dir, runner


def first_layer_inputs(state_dict: dict) -> int:
    """Input width of an MLP's first linear layer in a saved state dict."""
    weights = [v for k, v in state_dict.items() if k.endswith("weight") and v.ndim == 2]
    return int(weights[0].shape[1])


def test_three_ppo_iterations_with_asymmetric_critic(run):
    run_dir, runner = run
    assert runner.current_learning_iteration == 2
    latest = load_checkpoint(run_dir / "latest.pt")
    assert latest["iter"] == 2
    meta = latest["infos"]["meta"]
    assert meta["actor_obs_dim"] == 87 and meta["critic_obs_dim"] == 104
    assert first_layer_inputs(latest["actor_state_dict"]) == 87
    assert first_layer_inputs(latest["critic_state_dict"]) == 104
    assert latest["infos"]["env_steps"] == 3 * 24 * 16
    assert set(latest["infos"]["curriculum"]) == {"stage", "level", "outcomes"}
    for state in (latest["actor_state_dict"], latest["critic_state_dict"]):
        assert all(torch.isfinite(v).all() for v in state.values() if v.is_floating_point())
    assert sorted(p.name for p in run_dir.glob("model_*.pt"))  # numbered checkpoints kept
    config = json.loads((run_dir / "config.json").read_text())
    assert config["env_config"]["num_envs"] == 16 and config["env_config"]["num_threads"] == 1


def test_the_trained_policy_plays_through_onnx(run):
    """The exported actor under onnxruntime (as ``play --policy``) equals the torch actor."""
    from hybrid_recovery.evaluation.play import onnx_policy
    from hybrid_recovery.training.export import actor_from_checkpoint, export_policy

    run_dir, _ = run
    policy = onnx_policy(export_policy(run_dir))
    obs = torch.randn(4, 87, generator=torch.Generator().manual_seed(0))
    actions = np.concatenate([policy(row[None]) for row in obs.numpy()])  # batch of 1
    assert actions.shape == (4, 27)
    actor = actor_from_checkpoint(load_checkpoint(run_dir / "latest.pt"))
    with torch.no_grad():
        expected = actor.as_onnx(verbose=False)(obs)
    torch.testing.assert_close(torch.from_numpy(actions), expected, atol=1e-5, rtol=1e-5)
