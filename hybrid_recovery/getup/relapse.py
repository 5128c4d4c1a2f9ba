"""When the ground moves take over from a policy that lies still: :class:`GetupConfig`,
:func:`lying_still` and the moves' event rows (used by the ``model`` and ``hybrid``
controllers, :mod:`hybrid_recovery.controllers`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from hybrid_recovery.checks import NON_NEGATIVE, POSITIVE, Range, check_fields
from hybrid_recovery.getup.move_executor import GroundMoves, MoveConfig, base_speed
from hybrid_recovery.robot import constants


@dataclass(frozen=True)
class GetupConfig:
    """When the ground moves take over.

    Attributes:
        moves: Settings of the moves (goal = the hand-over state).
        policy_first: On the ground the policy acts first and the moves only once it lies
            still (a relapse, below). False: a robot that starts on the ground starts with
            the moves, for a policy that does not rise from the ground itself.
        ground_com_height: Below this CoM height a robot the QP does not apply to is on
            the ground [m] (kneeling and squatting starts, with the CoM near 0.55 m, are
            not).
        relapse_time: How long the robot lies still under the policy (CoM below
            ``ground_com_height``, joints slower than ``still_joint_speed``, base slower
            than ``still_base_speed``) before the ground moves start again [s]. Why 3 s:
            ``docs/experiments.md`` §9.
        still_joint_speed: Largest joint speed |q̇_j| of a robot lying still [rad/s] (a
            policy still trying to rise moves some joint at several rad/s; one that has
            given up twitches below ~1 rad/s).
        still_base_speed: Largest pelvis speed |v_b| of a robot lying still [m/s].
        max_relapses: Most such starts of the moves under the policy per episode.
    """

    moves: MoveConfig = field(default_factory=MoveConfig)
    policy_first: bool = True
    ground_com_height: float = 0.45
    relapse_time: float = 3.0
    still_joint_speed: float = 2.0
    still_base_speed: float = 0.2
    max_relapses: int = 2

    def __post_init__(self) -> None:
        check_config(self)


RANGES: dict[str, Range] = {"ground_com_height": POSITIVE, "relapse_time": NON_NEGATIVE,
                            "still_joint_speed": POSITIVE, "still_base_speed": POSITIVE,
                            "max_relapses": NON_NEGATIVE}
"""Field of :class:`GetupConfig` → its range."""


def check_config(config: GetupConfig) -> None:
    """Every number of ``config`` finite and in its range (:data:`RANGES`).

    Raises:
        ValueError: e.g. ``GetupConfig.relapse_time must be >= 0, got -1.0``.
    """
    check_fields(config, RANGES)


def com_height(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """CoM height h_c of the robot (the pelvis subtree) [m]."""
    return float(data.subtree_com[model.body("pelvis").id, 2])


def lying_still(model: mujoco.MjModel, data: mujoco.MjData, config: GetupConfig) -> bool:
    """Whether the robot lies still on the ground: h_c < ``ground_com_height``,
    max_j |q̇_j| < ``still_joint_speed`` over the 27 actuated joints and the pelvis speed
    |v_b| < ``still_base_speed``."""
    if com_height(model, data) >= config.ground_com_height:
        return False
    joints = data.qvel[model.jnt_dofadr[1:1 + constants.NUM_JOINTS]]
    return bool(np.abs(joints).max() < config.still_joint_speed
                and base_speed(model, data) < config.still_base_speed)


def move_events(moves: GroundMoves) -> list[tuple[float, str, str]]:
    """The moves' events as (time [s], kind, message) rows."""
    return [(round(e.time, 3), e.kind, e.message) for e in moves.events]
