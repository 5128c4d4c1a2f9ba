"""Left/right mirror of observations and actions for rsl-rl's symmetry augmentation.

The mirror is the reflection y → −y through the robot's sagittal plane. Polar vectors
(positions, velocities, forces, gravity) flip their y component; axial vectors (angular
velocity and momentum) flip x and z. Joints map left ↔ right with the signs of
``constants.MIRROR_SIGN`` (roll and yaw axes flip).
"""

from __future__ import annotations

import torch
from tensordict import TensorDict

from hybrid_recovery.robot import constants

_POLAR = torch.tensor([1.0, -1.0, 1.0])
_AXIAL = torch.tensor([-1.0, 1.0, -1.0])
_JOINT_INDEX = torch.tensor(constants.MIRROR_JOINT_INDEX.tolist())
_JOINT_SIGN = torch.tensor(constants.MIRROR_SIGN.tolist(), dtype=torch.float32)
_N = constants.NUM_JOINTS


def mirror_joints(x: torch.Tensor) -> torch.Tensor:
    """Mirrors (..., 27) joint quantities."""
    return x[..., _JOINT_INDEX] * _JOINT_SIGN


def mirror_actor_obs(obs: torch.Tensor) -> torch.Tensor:
    """Mirrors the 87-wide actor observation (see ``observation.actor``)."""
    out = obs.clone()
    out[..., 0:3] = obs[..., 0:3] * _AXIAL
    out[..., 3:6] = obs[..., 3:6] * _POLAR
    for start in (6, 6 + _N, 6 + 2 * _N):
        out[..., start:start + _N] = mirror_joints(obs[..., start:start + _N])
    return out


def mirror_critic_obs(obs: torch.Tensor) -> torch.Tensor:
    """Mirrors the critic observation: the actor part, then the 17 privileged entries
    (CoM position, velocity, acceleration, p_l: polar; L: axial; ξ − p_c,xy: polar)."""
    out = obs.clone()
    out[..., :87] = mirror_actor_obs(obs[..., :87])
    if obs.shape[-1] > 87:
        for k, kind in enumerate((_POLAR, _POLAR, _POLAR, _POLAR, _AXIAL)):
            s = 87 + 3 * k
            out[..., s:s + 3] = obs[..., s:s + 3] * kind
        out[..., 102:104] = obs[..., 102:104] * _POLAR[:2]
    return out


def mirror_batch(env=None, obs: TensorDict | None = None, actions: torch.Tensor | None = None):
    """rsl-rl data-augmentation function: returns the batch followed by its mirror."""
    del env
    obs_out = None
    if obs is not None:
        obs_out = TensorDict({"policy": torch.cat([obs["policy"], mirror_actor_obs(obs["policy"])]),
                              "critic": torch.cat([obs["critic"],
                                                   mirror_critic_obs(obs["critic"])])},
                             batch_size=[2 * obs.batch_size[0]])
    act_out = None if actions is None else torch.cat([actions, mirror_joints(actions)])
    return obs_out, act_out
