"""``hybrid-recovery bench``: the dynamics bench runs end to end and its JSON parses."""

from __future__ import annotations

import importlib.util
import json
import time
from collections import defaultdict

import numpy as np
import pytest
import torch

from hybrid_recovery.bench import BENCHES, run_dynamics_bench
from hybrid_recovery.bench.dynamics import MJ_FORWARD, random_states
from hybrid_recovery.bench.env import _timed
from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.timing import best_seconds, device_sync
from hybrid_recovery.bench.update_parts import UPDATE_PARTS, fill_storage, time_update_parts
from hybrid_recovery.cli.main import main

QUANTITIES = {"balance_state", "centroidal_momentum_matrix", "centroidal_momentum_drift",
              MJ_FORWARD, "mj_kinematics..subtreeVel"}


@pytest.fixture(scope="module")
def result() -> BenchResult:
    return run_dynamics_bench(n=8, repeat=1)


def test_dynamics_bench_figures(result):
    figures = json.loads(result.json_line())
    assert set(figures) == {"bench", "n", "repeat", "us_per_state", "ratio_to_mj_forward",
                            "max_rel_error_vs_mujoco", "cpu_count", "loadavg_1min"}
    assert figures["bench"] == "dynamics" and figures["n"] == 8 and figures["repeat"] == 1
    assert set(figures["us_per_state"]) == QUANTITIES == set(figures["ratio_to_mj_forward"])
    for name in QUANTITIES:
        assert figures["us_per_state"][name] > 0.0
        assert figures["ratio_to_mj_forward"][name] == pytest.approx(
            figures["us_per_state"][name] / figures["us_per_state"][MJ_FORWARD])
    # Both sides of the comparison compute the same CoM and momenta.
    assert figures["max_rel_error_vs_mujoco"] < 1e-9


def test_dynamics_bench_table(result):
    lines = result.table().splitlines()
    assert lines[1].split() == ["quantity", "us/state", "ratio"]
    assert {line.split()[0] for line in lines[3:]} == QUANTITIES


def test_cli_prints_table_then_json(capsys):
    assert main(["bench", "dynamics", "-n", "4", "--repeat", "1", "--seed", "1"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    figures = json.loads(lines[-1])
    assert figures["bench"] == "dynamics" and figures["n"] == 4
    assert lines[0].startswith("bench dynamics: N = 4 random H1-2 states")


def test_cli_rejects_unknown_bench(capsys):
    with pytest.raises(SystemExit):
        main(["bench", "nonsense"])
    assert "invalid choice: 'nonsense'" in capsys.readouterr().err


def test_dispatch_table_lists_dynamics():
    assert "dynamics" in BENCHES
    assert all(callable(fn) for fn in BENCHES.values())


def test_bad_sizes_have_clear_errors():
    with pytest.raises(ValueError, match=r"^n must be >= 1, got 0$"):
        run_dynamics_bench(n=0)
    with pytest.raises(ValueError, match=r"^repeat must be >= 1, got 0$"):
        run_dynamics_bench(n=4, repeat=0)
    with pytest.raises(ValueError, match=r"^repeat must be >= 1, got 0$"):
        best_seconds(lambda: None, 0)


def test_random_states_are_valid(own_model):
    qpos, qvel = random_states(own_model.mj_model, 16, np.random.default_rng(0))
    assert qpos.shape == (16, own_model.nq) and qvel.shape == (16, own_model.nv)
    np.testing.assert_allclose(np.linalg.norm(qpos[:, 3:7], axis=1), 1.0)
    low, high = own_model.mj_model.jnt_range[1:].T
    assert np.all((qpos[:, 7:] >= low) & (qpos[:, 7:] <= high))


def test_env_bench_reports_rates_and_split():
    from hybrid_recovery.bench import run_env_bench

    result = run_env_bench(n=4, repeat=1, steps=3, threads=1,
                           overrides={"physics_dt": 0.01, "decimation": 2})
    figures = json.loads(result.json_line())
    assert figures["bench"] == "env" and figures["num_envs"] == 4
    assert figures["backend"] == "batch" and figures["device"] == "cpu"
    assert figures["physics_dt"] == 0.01
    assert figures["env_steps_per_s"] > 0 and figures["physics_steps_per_s"] > 0
    assert set(figures["ms_per_step"]) == {"physics", "state_and_hulls", "observations",
                                           "resets", "rewards_terminations_other"}



def test_a_timed_part_ends_when_its_device_work_is_done():
    """With a device's sync (a GPU's ``torch.cuda.synchronize``) a timed part lasts until
    the sync returns, not only until its launches return; the CPU has none."""
    class Part:
        def launch(self):
            return "queued"

    totals: dict[str, float] = defaultdict(float)
    part, done = Part(), []
    _timed(part, "launch", totals, sync=lambda: (time.sleep(0.05), done.append(True)))
    assert part.launch() == "queued" and done == [True]
    assert totals["launch"] >= 0.05
    assert device_sync("cpu") is None


def test_terms_bench_times_numpy_and_torch_on_the_same_arrays():
    import torch

    from hybrid_recovery.bench import run_terms_bench

    result = run_terms_bench(n=8, repeat=2, steps=2)
    figures = json.loads(result.json_line())
    assert figures["bench"] == "terms" and figures["num_envs"] == 8
    assert figures["device"] == "cpu" and figures["numpy_ms"] > 0 and figures["torch_ms"] > 0
    # the figures are rounded to 3 decimals
    assert figures["ratio"] == pytest.approx(figures["numpy_ms"] / figures["torch_ms"], abs=1e-3)
    for name in ("numpy", "torch"):
        parts = figures["ms"][name]
        assert set(parts) == {"state_and_hulls", "rewards", "observations"}
        assert sum(parts.values()) == pytest.approx(figures[f"{name}_ms"], abs=2e-3)
    assert [row[0] for row in result.rows] == ["state_and_hulls", "rewards", "observations",
                                               "all"]
    if not torch.cuda.is_available():
        with pytest.raises(ValueError, match="needs a CUDA GPU"):
            run_terms_bench(n=8, device="cuda")


_WARP = pytest.mark.skipif(importlib.util.find_spec("mujoco_warp") is None,
                           reason="MuJoCo Warp not installed (the 'warp' extra)")


@pytest.mark.parametrize("backend", ["batch", pytest.param("warp", marks=[pytest.mark.warp,
                                                                         _WARP])])
def test_physics_replay_is_the_env_runs_physics(backend):
    """Without resets, replaying the recorded controls and pushes from the start state
    ends in the env run's own state, bit for bit; and the env carries on from there."""
    from hybrid_recovery.bench.physics_replay import PhysicsReplay
    from hybrid_recovery.envs import RecoveryEnv, default_config

    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed, cfg.backend = 4, 1, 3, backend
    env = RecoveryEnv(cfg)
    replay = PhysicsReplay(env)
    with pytest.raises(RuntimeError, match=r"^PhysicsReplay.replay\(\) needs start\(\) first$"):
        replay.replay()
    replay.start()
    gen = torch.Generator().manual_seed(0)
    for _ in range(3):
        _, _, done, _ = env.step(torch.randn(4, 27, generator=gen) * 0.3)
        assert not done.any()
    end = {f: env.sims.bind(f).copy() for f in ("qpos", "qvel")}
    assert replay.steps == 3 * 4 and replay.replay() > 0.0
    for field, value in end.items():
        np.testing.assert_array_equal(replay.replayed[field], value)
        np.testing.assert_array_equal(env.sims.bind(field), value)
    assert not np.array_equal(replay.replayed["qpos"], replay._start["qpos"])


@pytest.fixture(scope="module")
def train_bench() -> dict:
    from hybrid_recovery.bench import run_train_bench

    return json.loads(run_train_bench(n=4, repeat=1, threads=1).json_line())


def test_train_bench_reports_split_and_physics_rate(train_bench):
    figures = train_bench
    assert figures["env_steps_per_s"] > 0 and figures["physics_steps_per_s"] > 0
    # the physics alone is a part of the iteration: it must run faster
    assert figures["physics_steps_per_s"] > figures["env_steps_per_s"]
    assert figures["ratio"] == pytest.approx(
        figures["env_steps_per_s"] / figures["physics_steps_per_s"], abs=1e-3)
    assert set(figures["s_per_iteration"]) == {"simulation", "observation_reward",
                                               "policy_inference_and_storage", "ppo_update"}
    settings = dict(figures["settings"])
    assert settings.pop("omp_wait_policy") in (None, "PASSIVE", "ACTIVE")  # as the env has it
    # unset, the precision is the machine's choice, and the bench says which and why
    choice = settings.pop("precision_choice")
    assert choice.startswith(("bf16: measured", "fp32: measured"))
    assert settings.pop("mixed_precision") is choice.startswith("bf16")
    assert settings == {"backend": "batch", "device": "cpu", "threads": 1, "torch_threads": 1,
                        "num_learning_epochs": 5,
                        "num_mini_batches": 4, "symmetry": False}


def test_train_bench_splits_the_update(train_bench):
    parts = train_bench["update_s_per_iteration"]
    assert list(parts) == [*UPDATE_PARTS, "rest"]
    assert all(parts[name] >= 0.0 for name in UPDATE_PARTS)  # rounded to 1 ms
    assert parts["actor_backward"] > 0.0 and parts["critic_backward"] > 0.0
    assert parts["symmetry_augmentation"] == 0.0  # symmetry is off
    # the parts and rest add up to the update; each of the ten figures is rounded to 1 ms
    assert sum(parts.values()) == pytest.approx(train_bench["s_per_iteration"]["ppo_update"],
                                                abs=10 * 0.5e-3)


def test_update_parts_leave_the_learner_as_it_was():
    import contextlib
    import copy
    import io

    from hybrid_recovery.envs import RecoveryEnv
    from hybrid_recovery.training.config import TrainConfig, runner_dict
    from hybrid_recovery.training.runner import RecoveryRunner, make_env_config

    cfg = TrainConfig(num_envs=4, num_threads=1)
    cfg.ppo.symmetry, cfg.ppo.mixed_precision = True, True
    env = RecoveryEnv(make_env_config(cfg))
    with contextlib.redirect_stdout(io.StringIO()):
        runner = RecoveryRunner(env, runner_dict(cfg), None, meta={})
    fill_storage(runner)
    alg = runner.alg
    alg.optimizer.step()  # an Adam state to keep
    before = copy.deepcopy((alg.actor.state_dict(), alg.critic.state_dict(),
                            alg.optimizer.state_dict()["state"]))
    parts = time_update_parts(alg, repeat=1)
    assert list(parts) == list(UPDATE_PARTS) and all(v > 0.0 for v in parts.values())
    after = (alg.actor.state_dict(), alg.critic.state_dict(), alg.optimizer.state_dict()["state"])
    for old, new in zip(before[:2], after[:2], strict=True):
        assert old.keys() == new.keys()
        assert all(torch.equal(old[k], new[k]) for k in old)
    for k, state in before[2].items():
        assert all(torch.equal(v, after[2][k][name]) for name, v in state.items())
    assert all(p.grad is None or not p.grad.any() for p in alg.actor.parameters())


def test_bench_train_settings_are_checked():
    from hybrid_recovery.bench.train import bench_train_config

    cfg = bench_train_config(8, 0, 1, {"torch_threads": 1, "ppo.mixed_precision": True})
    assert cfg.torch_threads == 1 and cfg.ppo.mixed_precision and cfg.num_envs == 8
    with pytest.raises(KeyError, match=r"unknown training setting 'ppo.epochs'; known: "):
        bench_train_config(8, 0, 1, {"ppo.epochs": 2})
    with pytest.raises(KeyError, match=r"unknown training setting 'threads'; known: "):
        bench_train_config(8, 0, 1, {"threads": 2})
    with pytest.raises(ValueError, match=r"^config key 'train.torch_threads' must be >= 1, "
                                         r"got 0$"):
        bench_train_config(8, 0, 1, {"torch_threads": 0})
    with pytest.raises(ValueError, match=r"^config key 'ppo.mixed_precision' must be "):
        bench_train_config(8, 0, 1, {"ppo.mixed_precision": "yes"})


def test_cli_bench_train_takes_train_settings(capsys):
    assert main(["bench", "train", "-n", "4", "--repeat", "1",
                 "--set", "torch_threads=1", "ppo.mixed_precision=true"]) == 0
    figures = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert figures["settings"]["torch_threads"] == 1
    assert figures["settings"]["mixed_precision"] is True
    assert figures["ratio_noise_at_start"] > 0.0  # bf16 rounding, see test_mixed_precision


def test_qp_timing_replays_the_live_episode_recorded_apart(monkeypatch):
    """The live figures come from an episode whose QPs are not copied for the replays
    (the copy sat inside the timed tick); the replays solve as many QPs as it ran."""
    from hybrid_recovery.bench import qp as bench_qp
    from hybrid_recovery.control.wbc_qp import WholeBodyQP

    recording_during_live: list[bool] = []
    solve = WholeBodyQP.solve

    def spy(self, state, tasks, stance):
        recording_during_live.append(self.recorder is not None)
        return solve(self, state, tasks, stance)

    monkeypatch.setattr(WholeBodyQP, "solve", spy)
    out = bench_qp.solve_timing(duration=0.3, log=lambda line: None)
    half = len(recording_during_live) // 2
    assert half > 0 and not any(recording_during_live[:half])
    assert all(recording_during_live[half:])
    assert out["live_tick"]["n"] == out["proxsuite_dense_warm"]["n"] == half
    for name in ("live_solve", "live_tick", "proxsuite_dense_warm", "proxsuite_dense_cold",
                 "qpsolvers_proxqp"):
        assert 0.0 < out[name]["median_ms"] <= out[name]["p99_ms"] <= out[name]["max_ms"]
