"""Several training processes (``torchrun``): each rank's device and seed, only rank 0
writes the run, and two CPU processes train one policy over gloo (the collectives of
rsl-rl's multi-GPU mode; NCCL between GPUs needs GPUs and is not run here)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from test_teacher import recording  # noqa: F401  (the fixture: a recorded rise)

from hybrid_recovery.training import train
from hybrid_recovery.training.checkpoint import load_checkpoint
from hybrid_recovery.training.config import TrainConfig
from hybrid_recovery.training.distributed import Rank, process_rank


def test_one_process_without_torchrun():
    assert process_rank({}) == Rank(1, 0, 0)
    assert process_rank({"WORLD_SIZE": "1"}) == Rank(1, 0, 0)


def test_torchrun_ranks_get_their_gpu_and_seed():
    rank = process_rank({"WORLD_SIZE": "4", "RANK": "3", "LOCAL_RANK": "1"})
    assert rank == Rank(4, 3, 1)
    assert rank.learner_device("cuda") == "cuda:1"
    assert rank.seed(7) == 10
    assert not rank.writes and Rank(4, 0, 0).writes


def test_a_rank_outside_the_world_is_refused():
    with pytest.raises(ValueError) as err:
        process_rank({"WORLD_SIZE": "2", "RANK": "2", "LOCAL_RANK": "0"})
    assert str(err.value) == "RANK 2 and LOCAL_RANK 0 must be in [0, 2)"


def test_only_rank_zero_writes_and_ranks_draw_different_episodes(tmp_path):
    cfg = TrainConfig(num_envs=8, iterations=2, save_interval=1, num_threads=1,
                      hidden_dims=(32, 32), seed=5)
    runs = {}
    for k in (0, 1):
        run_dir = tmp_path / f"rank{k}"
        runs[k] = train(run_dir, cfg, rank=Rank(world_size=2, rank=k, local_rank=0))
    assert not (tmp_path / "rank1").exists()
    written = sorted(p.name for p in (tmp_path / "rank0").iterdir())
    assert "config.json" in written and "latest.pt" in written
    assert runs[0].env.cfg.seed == 5 and runs[1].env.cfg.seed == 6
    assert not np.array_equal(runs[0].env.qpos, runs[1].env.qpos)


def test_a_resume_runs_where_it_is_told_and_learns_what_it_learnt(tmp_path):
    """Backend and device are where a run runs (taken from the resume's options); what it
    learns (here the seed and the network) stays the run's own."""
    import dataclasses
    import json

    from hybrid_recovery.training.runner import _resumed_config

    saved = TrainConfig(num_envs=8, seed=5, hidden_dims=(32, 32))
    (tmp_path / "config.json").write_text(json.dumps(
        {"train_config": dataclasses.asdict(saved)}))
    now = TrainConfig(num_envs=8, seed=9, backend="warp", device="cuda")
    resumed = _resumed_config(tmp_path, now, given={"backend", "device", "seed"})
    assert (resumed.backend, resumed.device) == ("warp", "cuda")
    assert resumed.seed == 5 and resumed.hidden_dims == (32, 32)


def _torchrun(out: Path, rises: Path, mode: str) -> list[dict]:
    """Two CPU processes of ``distributed_worker.py``; what each rank saved."""
    done = subprocess.run(
        [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2",
         str(Path(__file__).parent / "distributed_worker.py"), str(out), str(rises), mode],
        capture_output=True, text=True, timeout=600, env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return [torch.load(out / f"rank{k}.pt") for k in (0, 1)]


@pytest.mark.slow
def test_two_cpu_processes_train_one_policy(tmp_path, recording):  # noqa: F811
    """``torchrun --nproc_per_node=2`` on the CPU (gloo): rsl-rl's distributed mode with the
    training's update and the teacher. Each rank simulates its own episodes, yet after
    three updates both hold the same networks, normalisers and step size (the
    gradients, the teacher's among them, and the statistics are all-reduced), which
    moved from where they started; only rank 0 wrote the run, counting both ranks' steps."""
    ranks = _torchrun(tmp_path, recording[0], "train")
    for net in ("actor", "critic"):
        first, second = ranks[0][net], ranks[1][net]
        assert first.keys() == second.keys()
        for key in first:
            assert torch.equal(first[key], second[key]), f"{net}.{key}"
    assert ranks[0]["learning_rate"] == ranks[1]["learning_rate"]
    assert not torch.equal(ranks[0]["qpos"], ranks[1]["qpos"])  # their own episodes
    saved = load_checkpoint(tmp_path / "run" / "latest.pt")
    assert saved["iter"] == 2 and saved["infos"]["env_steps"] == 3 * 4 * 8 * 2
    started = load_checkpoint(tmp_path / "run" / "model_0.pt")["actor_state_dict"]
    assert not torch.equal(started["mlp.0.weight"], ranks[0]["actor"]["mlp.0.weight"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rank0.pt", "rank1.pt", "run"]


@pytest.mark.slow
def test_a_stop_asked_on_one_rank_stops_every_rank_after_the_same_iteration_saved(
        tmp_path, recording):  # noqa: F811
    """SIGTERM to rank 1 alone (as when one node of a job is preempted): both ranks end
    after iteration 1, rank 0 having saved it; alone, rank 1 would have left and rank 0
    waited for it in the next update's all-reduce."""
    ranks = _torchrun(tmp_path, recording[0], "stop-on-rank-1")
    assert ranks[1]["ended"] == "SIGTERM: stopped after iteration 1, saved; continue with --resume"
    assert ranks[0]["ended"] == ("a stop asked on another rank: stopped after iteration 1, "
                                 "saved; continue with --resume")
    assert load_checkpoint(tmp_path / "run" / "latest.pt")["iter"] == 1
    assert (tmp_path / "run" / "model_1.pt").is_file()
