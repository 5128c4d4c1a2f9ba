"""One rank of the ``torchrun`` runs of :mod:`test_distributed`: a short run with the
teacher, then what this rank holds saved to ``<out>/rank<RANK>.pt``.

``train``: three iterations; the networks, step size and env's state are saved.
``stop-on-rank-1``: rank 1 alone is sent SIGTERM during its second iteration; how each
rank's run ended is saved.
"""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import torch

from hybrid_recovery.envs.recovery_env import RecoveryEnv
from hybrid_recovery.training.config import TeacherConfig, TrainConfig
from hybrid_recovery.training.graceful_stop import TrainingStopped
from hybrid_recovery.training.runner import train

out, recording, mode = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
rank = int(os.environ["RANK"])
STEPS = 4
if mode == "stop-on-rank-1" and rank == 1:
    step, calls = RecoveryEnv.step, [0]

    def signalled_step(env, actions):
        calls[0] += 1
        if calls[0] == STEPS + 2:  # within iteration 1's rollout
            os.kill(os.getpid(), signal.SIGTERM)
        return step(env, actions)

    RecoveryEnv.step = signalled_step  # type: ignore[method-assign]

overrides = {"curriculum.enabled": False, "pose_weights": {"sitting": 1.0, "standing": 1.0},
             "rises.files": [recording], "rises.levels": 1, "rises.window": 100_000}
cfg = TrainConfig(num_envs=8, num_steps_per_env=STEPS, iterations=3 if mode == "train" else 6,
                  save_interval=10, num_threads=1, hidden_dims=(32, 32), seed=5,
                  env_overrides=overrides,
                  teacher=TeacherConfig(learning_rate=1e-3, anneal_iterations=10, steps=2,
                                        batch_size=16))
if mode == "train":
    runner = train(out / "run", cfg)
    torch.save({"actor": runner.alg.actor.state_dict(),
                "critic": runner.alg.critic.state_dict(),
                "learning_rate": runner.alg.learning_rate,
                "qpos": torch.from_numpy(runner.env.qpos.copy())}, out / f"rank{rank}.pt")
else:
    try:
        train(out / "run", cfg)
        ended = "ran to the end"
    except TrainingStopped as stopped:
        ended = str(stopped)
    torch.save({"ended": ended}, out / f"rank{rank}.pt")
