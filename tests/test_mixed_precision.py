"""bf16 PPO update (``PPOConfig.mixed_precision``) and the torch thread count: float32
master weights, losses close to float32 on one fixed batch, and both options kept by a
run's config and checkpoints."""

from __future__ import annotations

import contextlib
import copy
import io
import json
from dataclasses import asdict

import pytest
import torch

from hybrid_recovery.bench.update_parts import fill_storage, ratio_noise
from hybrid_recovery.envs import RecoveryEnv
from hybrid_recovery.training import TrainConfig, load_checkpoint, train
from hybrid_recovery.training.config import runner_dict, train_config_from_dict
from hybrid_recovery.training.runner import RecoveryRunner, make_env_config

FAST = {"curriculum.window": 8, "curriculum.advance_success": 0.0}


@pytest.fixture(scope="module")
def filled():
    """A runner whose storage holds one 8-env × 24-step rollout, and that storage."""
    torch.manual_seed(0)
    cfg = TrainConfig(num_envs=8, num_threads=1, env_overrides=dict(FAST))
    cfg.ppo.mixed_precision = True
    env = RecoveryEnv(make_env_config(cfg))
    with contextlib.redirect_stdout(io.StringIO()):
        runner = RecoveryRunner(env, runner_dict(cfg), None, meta={})
    fill_storage(runner)
    storage = {k: v.clone() if torch.is_tensor(v) else v
               for k, v in vars(runner.alg.storage).items()}
    return runner, storage


def _update(runner, storage, mixed: bool, lr: float) -> tuple[dict, dict]:
    """One PPO update on a copy of ``storage`` from the same weights and the same
    mini-batch order; returns its mean losses and the weights after it."""
    alg = runner.alg
    start = copy.deepcopy((alg.actor.state_dict(), alg.critic.state_dict(),
                           alg.optimizer.state_dict()))
    for key, value in storage.items():
        setattr(alg.storage, key, value.clone() if torch.is_tensor(value) else value)
    alg.use_mixed_precision, alg.schedule, alg.learning_rate = mixed, "fixed", lr
    for group in alg.optimizer.param_groups:
        group["lr"] = lr
    torch.manual_seed(1)
    losses = alg.update()
    after = {n: p.detach().clone() for n, p in alg.actor.named_parameters()}
    alg.actor.load_state_dict(start[0])
    alg.critic.load_state_dict(start[1])
    alg.optimizer.load_state_dict(start[2])
    return losses, after


def test_mixed_precision_reaches_rsl_rl():
    cfg = TrainConfig()
    cfg.ppo.mixed_precision = True
    assert runner_dict(cfg)["algorithm"]["use_mixed_precision"] is True
    cfg.ppo.mixed_precision = False
    algorithm = runner_dict(cfg)["algorithm"]
    assert algorithm["use_mixed_precision"] is False and "mixed_precision" not in algorithm


def test_a_run_saved_before_bf16_resumes_in_float32():
    """A saved ``train_config`` without ``ppo.mixed_precision`` was trained in float32
    (the shipped record, the live lineage): it reads as float32, not as today's default."""
    saved = asdict(TrainConfig())
    del saved["ppo"]["mixed_precision"]
    assert train_config_from_dict(saved).ppo.mixed_precision is False
    saved["ppo"]["mixed_precision"] = True
    assert train_config_from_dict(saved).ppo.mixed_precision is True


def test_bf16_loss_close_to_fp32_on_a_fixed_batch(filled):
    """At learning rate 0 both updates see the same weights and mini-batches, so the
    losses differ only by bf16 rounding (8-bit mantissa, relative step 2⁻⁸ ≈ 0.4 %)."""
    runner, storage = filled
    fp32, _ = _update(runner, storage, mixed=False, lr=0.0)
    bf16, _ = _update(runner, storage, mixed=True, lr=0.0)
    assert bf16["value"] == pytest.approx(fp32["value"], rel=0.02)
    # the entropy of a Gaussian depends on its std alone, a float32 parameter
    assert bf16["entropy"] == pytest.approx(fp32["entropy"], rel=1e-6)
    # normalised advantages (mean |A| ≈ 0.8): a 1 % error in the ratio moves this ≲ 0.01
    assert abs(fp32["surrogate"]) < 1e-6
    assert abs(bf16["surrogate"] - fp32["surrogate"]) < 0.01
    # and the update is not a no-op: bf16 rounding does change the losses
    assert bf16["value"] != fp32["value"]


def test_bf16_update_keeps_float32_master_weights(filled):
    runner, storage = filled
    before = {n: p.detach().clone() for n, p in runner.alg.actor.named_parameters()}
    _, after = _update(runner, storage, mixed=True, lr=1e-3)
    weight = after["mlp.0.weight"]
    assert all(p.dtype == torch.float32 for p in after.values())
    assert not torch.equal(weight, before["mlp.0.weight"])
    # a bf16 master copy would hold only bf16-representable values
    assert (weight != weight.bfloat16().float()).float().mean() > 0.9
    # steps of lr = 1e-3 are far below a bf16 ulp of weights of size ~0.05: only a
    # float32 master copy can hold them
    step = (weight - before["mlp.0.weight"]).abs()
    assert 0.0 < step.max() < 2e-2 and step[step > 0].min() < 1e-4


def test_options_round_trip_through_config_and_checkpoint(tmp_path):
    cfg = TrainConfig(num_envs=4, iterations=1, save_interval=1, num_threads=1,
                      torch_threads=1, env_overrides=dict(FAST))
    cfg.ppo.mixed_precision = False  # not the default
    runner = train(tmp_path, cfg)
    assert runner.alg.use_mixed_precision is False
    assert torch.get_num_threads() == 1
    saved = json.loads((tmp_path / "config.json").read_text())["train_config"]
    assert saved["torch_threads"] == 1 and saved["ppo"]["mixed_precision"] is False
    assert train_config_from_dict(saved) == cfg
    meta = load_checkpoint(tmp_path / "latest.pt")["infos"]["meta"]
    assert train_config_from_dict(meta["train_config"]) == cfg
    # a resume keeps the run's precision and takes the thread counts given now
    again = TrainConfig(num_envs=4, iterations=2, num_threads=1, torch_threads=2)
    resumed = train(tmp_path, again, resume=True)
    assert resumed.alg.use_mixed_precision is False and torch.get_num_threads() == 2
    saved = json.loads((tmp_path / "config.json").read_text())["train_config"]
    assert saved["torch_threads"] == 2 and saved["ppo"]["mixed_precision"] is False
    torch.set_num_threads(1)


def test_precision_is_amendable(tmp_path):
    cfg = TrainConfig(num_envs=4, iterations=1, save_interval=1, num_threads=1,
                      env_overrides=dict(FAST))
    train(tmp_path, cfg)
    cfg.iterations = 2
    resumed = train(tmp_path, cfg, resume=True, amend={"ppo.mixed_precision": True})
    assert resumed.alg.use_mixed_precision is True
    saved = json.loads((tmp_path / "config.json").read_text())
    assert saved["amendments"][-1]["changes"] == {"ppo.mixed_precision": True}


def test_bf16_rounding_shows_in_the_ppo_ratio(filled):
    """Before any step θ = θold, so PPO's ratio is 1 up to rounding: float32 rounding is
    far below the clip range 0.2, bf16's (8-bit mantissa on the action mean) is not."""
    runner, storage = filled
    alg = runner.alg
    for key, value in storage.items():
        setattr(alg.storage, key, value.clone() if torch.is_tensor(value) else value)
    alg.use_mixed_precision = False
    fp32 = ratio_noise(alg)
    alg.use_mixed_precision = True
    bf16 = ratio_noise(alg)
    alg.use_mixed_precision = False
    assert fp32 < 1e-4
    assert 1e-3 < bf16 < 0.2


def test_cli_passes_precision_and_torch_threads(monkeypatch, tmp_path):
    import hybrid_recovery.training as training
    from hybrid_recovery.cli.main import main

    seen = {}
    monkeypatch.setattr(training, "train", lambda run_dir, cfg, **kw: seen.update(cfg=cfg))
    main(["train", "--run-dir", str(tmp_path), "--mixed-precision", "--torch-threads", "1",
          "--threads", "2"])
    assert seen["cfg"].ppo.mixed_precision is True
    assert (seen["cfg"].torch_threads, seen["cfg"].num_threads) == (1, 2)
    main(["train", "--run-dir", str(tmp_path)])  # the default: chosen by the machine
    assert seen["cfg"].ppo.mixed_precision is None and seen["cfg"].torch_threads is None
    main(["train", "--run-dir", str(tmp_path), "--no-mixed-precision"])
    assert seen["cfg"].ppo.mixed_precision is False
    main(["train", "--run-dir", str(tmp_path), "--variant", "recovery"])  # the shipped recipe
    assert seen["cfg"].ppo.mixed_precision is False
    main(["train", "--run-dir", str(tmp_path), "--variant", "recovery", "--mixed-precision"])
    assert seen["cfg"].ppo.mixed_precision is True
