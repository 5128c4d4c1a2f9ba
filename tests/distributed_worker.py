"""One rank of :func:`test_distributed.test_two_cpu_processes_train_one_policy` (run by
``torchrun``): a short run with the teacher, then this rank's networks and first
start poses saved to ``<out>/rank<RANK>.pt``."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import torch

from hybrid_recovery.training.config import TeacherConfig, TrainConfig
from hybrid_recovery.training.runner import train

out, recording = Path(sys.argv[1]), sys.argv[2]
overrides = {"curriculum.enabled": False, "pose_weights": {"sitting": 1.0, "standing": 1.0},
             "rises.files": [recording], "rises.levels": 1, "rises.window": 100_000}
cfg = TrainConfig(num_envs=8, num_steps_per_env=4, iterations=3, save_interval=1,
                  num_threads=1, hidden_dims=(32, 32), seed=5, env_overrides=overrides,
                  teacher=TeacherConfig(learning_rate=1e-3, anneal_iterations=10, steps=2,
                                        batch_size=16))
runner = train(out / "run", cfg)
torch.save({"actor": runner.alg.actor.state_dict(), "critic": runner.alg.critic.state_dict(),
            "learning_rate": runner.alg.learning_rate,
            "qpos": torch.from_numpy(runner.env.qpos.copy())},
           out / f"rank{os.environ['RANK']}.pt")
