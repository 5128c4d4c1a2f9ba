"""hybrid_recovery: humanoid balance and fall recovery for the Unitree H1-2.

Implements Poddar et al., "Embedding Classical Balance Control Principles in Reinforcement
Learning for Humanoid Recovery", arXiv 2603.08619; "paper §…" in the docstrings cites its
sections (§III-B learning architecture, §III-C observations, §III-D actions, §III-E rewards,
§III-F curriculum, §III-G randomisation, §IV experiments).

The flat public API; see the subpackages for the rest.
"""

# First: MuJoCo reads MUJOCO_GL when it is imported, so the OpenGL backend is chosen here.
from hybrid_recovery.sim import gl_backend  # noqa: F401

# isort: split
from hybrid_recovery.dynamics import GRAVITY, BalanceState, RobotModel, net_centroidal_wrench
from hybrid_recovery.dynamics.capturability import (
    capture_point,
    n_step_capture_margin,
    one_step_capture_region,
    zero_step_margin,
)
from hybrid_recovery.dynamics.support import center_of_pressure, signed_distance, support_polygon
from hybrid_recovery.observation import actor_observation
from hybrid_recovery.robot.mjcf import default_qpos, load_mjmodel

__all__ = [
    "GRAVITY",
    "BalanceState",
    "RobotModel",
    "actor_observation",
    "capture_point",
    "center_of_pressure",
    "default_qpos",
    "load_mjmodel",
    "n_step_capture_margin",
    "net_centroidal_wrench",
    "one_step_capture_region",
    "signed_distance",
    "support_polygon",
    "zero_step_margin",
]
__version__ = "0.1.0"
