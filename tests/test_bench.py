"""``hybrid-recovery bench``: the dynamics bench runs end to end and its JSON parses."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hybrid_recovery.bench import BENCHES, run_dynamics_bench
from hybrid_recovery.bench.dynamics import MJ_FORWARD, random_states
from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.timing import best_seconds
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
    assert figures["physics_dt"] == 0.01
    assert figures["env_steps_per_s"] > 0 and figures["physics_steps_per_s"] > 0
    assert set(figures["ms_per_step"]) == {"physics", "state_and_hulls", "observations",
                                           "resets", "rewards_terminations_other"}


def test_train_bench_reports_split():
    from hybrid_recovery.bench import run_train_bench

    figures = json.loads(run_train_bench(n=4, repeat=1, threads=1).json_line())
    assert figures["env_steps_per_s"] > 0
    assert set(figures["s_per_iteration"]) == {"simulation", "observation_reward",
                                               "policy_inference_and_storage", "ppo_update"}
