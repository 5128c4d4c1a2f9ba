"""The policy's observation: one builder for training, evaluation, sim-to-sim and the robot."""

from hybrid_recovery.observation.actor import (
    ACTOR_OBS_DIM,
    ACTOR_TERMS,
    actor_observation,
    projected_gravity,
)

__all__ = ["ACTOR_OBS_DIM", "ACTOR_TERMS", "actor_observation", "projected_gravity"]
