"""PPO training of the recovery policy (rsl-rl-lib 5)."""

from hybrid_recovery.training.checkpoint import load_checkpoint
from hybrid_recovery.training.config import PPOConfig, TrainConfig
from hybrid_recovery.training.runner import RecoveryRunner, train
from hybrid_recovery.training.variants import VARIANTS

__all__ = ["VARIANTS", "PPOConfig", "RecoveryRunner", "TrainConfig", "load_checkpoint", "train"]
