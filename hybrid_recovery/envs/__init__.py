"""The learned half's environment: batched MuJoCo H1-2 recovery MDP.

:class:`RecoveryEnv` (torch, rsl-rl) is imported on first access, so that the light
modules of this package (``config``, ``rewards``, …) load without torch. The scene, the
start poses and rendering are in :mod:`hybrid_recovery.sim`.
"""

from typing import TYPE_CHECKING, Any

from hybrid_recovery.envs.config import EnvConfig, apply_overrides, default_config

if TYPE_CHECKING:
    from hybrid_recovery.envs.recovery_env import RecoveryEnv

__all__ = ["EnvConfig", "RecoveryEnv", "apply_overrides", "default_config"]


def __getattr__(name: str) -> Any:
    if name == "RecoveryEnv":
        from hybrid_recovery.envs.recovery_env import RecoveryEnv

        return RecoveryEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
