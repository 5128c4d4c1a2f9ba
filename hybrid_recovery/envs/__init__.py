"""The learned half's environment: batched MuJoCo H1-2 recovery MDP."""

from hybrid_recovery.envs.config import EnvConfig, apply_overrides, default_config
from hybrid_recovery.envs.recovery_env import RecoveryEnv

__all__ = ["EnvConfig", "RecoveryEnv", "apply_overrides", "default_config"]
