"""CPU-dependent defaults: the update precision chosen by the machine
(``PPOConfig.mixed_precision = None``: the faster of the two measured, recorded in the
run's config and checkpoints) and the thread count (the CPUs the process may use)."""

from __future__ import annotations

import json

import pytest

from hybrid_recovery.training import TrainConfig, load_checkpoint, train
from hybrid_recovery.training import runner as runner_module
from hybrid_recovery.training.config import runner_dict
from hybrid_recovery.training.precision import (
    PrecisionChoice,
    choose_precision,
    cpu_flags,
    time_update_pass,
)

FAST = {"curriculum.window": 8, "curriculum.advance_success": 0.0}


def _stub(fp32: float, bf16: float):
    calls: list[bool] = []

    def timer(mixed: bool) -> float:
        calls.append(mixed)
        return bf16 if mixed else fp32

    return timer, calls


@pytest.mark.parametrize(("fp32", "bf16", "mixed"), [(0.30, 0.12, True), (0.04, 0.31, False),
                                                     (0.10, 0.10, False)])
def test_the_faster_measured_precision_is_chosen(fp32, bf16, mixed):
    timer, calls = _stub(fp32, bf16)
    choice = choose_precision((97, 160), (512, 256, 128), 27, 6144, pairs=3, timer=timer,
                              flags=frozenset({"avx2"}))
    assert choice.mixed_precision is mixed
    assert (choice.fp32_s, choice.bf16_s) == (fp32, bf16)
    assert calls == [False, True] * 3  # alternating pairs
    assert choice.native_bf16 is False
    assert choice.reason == (f"{'bf16' if mixed else 'fp32'}: measured {bf16 * 1e3:.1f} ms "
                             f"bf16 vs {fp32 * 1e3:.1f} ms fp32 per mini-batch pass; native "
                             f"bf16 no")


def test_the_best_of_noisy_pairs_decides():
    times = iter([0.5, 0.2, 0.1, 0.25, 0.4, 0.3])  # fp32 best 0.1, bf16 best 0.2

    choice = choose_precision((4, 5), (8,), 2, 16, pairs=3, timer=lambda mixed: next(times),
                              flags=frozenset({"avx512_bf16"}))
    assert choice.mixed_precision is False and choice.native_bf16 is True


def test_cpu_flags_read_from_cpuinfo(tmp_path):
    info = tmp_path / "cpuinfo"
    info.write_text("processor\t: 0\nflags\t\t: fpu avx2 avx512_bf16\n\nflags : other\n")
    assert cpu_flags(info) == frozenset({"fpu", "avx2", "avx512_bf16"})
    assert cpu_flags(tmp_path / "missing") == frozenset()


def test_a_real_pass_is_timed_in_both_precisions():
    import torch

    from hybrid_recovery.training.precision import _networks

    nets = _networks((6, 9), (16, 8), 3)
    gen = torch.Generator().manual_seed(0)
    assert time_update_pass(False, nets, 32, gen) > 0.0
    assert time_update_pass(True, nets, 32, gen) > 0.0
    assert all(p.grad is not None for net in nets for p in net.parameters())


def test_runner_dict_needs_a_choice_when_the_machine_chooses():
    cfg = TrainConfig()
    assert cfg.ppo.mixed_precision is None  # the default: chosen by the machine
    with pytest.raises(ValueError, match="^ppo.mixed_precision is None \\(chosen by the "
                       "machine\\): pass the PrecisionChoice of choose_precision$"):
        runner_dict(cfg)
    choice = PrecisionChoice(True, "bf16: stub")
    assert runner_dict(cfg, choice)["algorithm"]["use_mixed_precision"] is True


def test_the_choice_is_recorded_in_config_and_checkpoints(tmp_path, monkeypatch):
    choices = iter([PrecisionChoice(False, "fp32: stub A", 0.1, 0.5, False),
                    PrecisionChoice(True, "bf16: stub B", 0.5, 0.1, True)])
    monkeypatch.setattr(runner_module, "choose_precision", lambda *a, **k: next(choices))
    cfg = TrainConfig(num_envs=4, iterations=1, save_interval=1, num_threads=1,
                      env_overrides=dict(FAST))
    run = train(tmp_path, cfg)
    assert run.alg.use_mixed_precision is False
    saved = json.loads((tmp_path / "config.json").read_text())
    assert saved["train_config"]["ppo"]["mixed_precision"] is None  # stays the machine's
    assert saved["precision"]["reason"] == "fp32: stub A"
    cfg.iterations = 2
    resumed = train(tmp_path, cfg, resume=True)  # chosen again on this segment's machine
    assert resumed.alg.use_mixed_precision is True
    segments = load_checkpoint(tmp_path / "latest.pt")["infos"]["segments"]
    assert [s["precision"]["reason"] for s in segments] == ["fp32: stub A", "bf16: stub B"]


def test_a_set_precision_is_not_measured(tmp_path, monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("measured although the run sets its precision")

    monkeypatch.setattr(runner_module, "choose_precision", refuse)
    cfg = TrainConfig(num_envs=4, iterations=1, save_interval=1, num_threads=1,
                      env_overrides=dict(FAST))
    cfg.ppo.mixed_precision = True
    assert train(tmp_path, cfg).alg.use_mixed_precision is True
    saved = json.loads((tmp_path / "config.json").read_text())
    assert saved["precision"]["reason"] == "bf16: set by the run's settings (ppo.mixed_precision)"


def test_the_thread_default_is_the_cpus_the_process_may_use(monkeypatch):
    import os

    from hybrid_recovery.training.config import usable_cpus

    assert TrainConfig().num_threads == usable_cpus() == len(os.sched_getaffinity(0))
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2, 3, 4, 5})
    assert TrainConfig().num_threads == 6
