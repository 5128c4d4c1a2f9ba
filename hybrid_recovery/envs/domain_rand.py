"""Per-episode domain randomisation (paper §III-G) on the physics batch's per-world model fields.

Ranges are widened from nominal by ``scale`` ∈ [0, 1] (the curriculum's difficulty): a
multiplier range (a, b) becomes (1 + scale (a − 1), 1 + scale (b − 1)); absolute ranges
(joint friction, contact friction, restitution) are interpolated from their nominal value.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.envs.config import DomainRandConfig
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.backend import PhysicsBatch

RANDOMIZED_FIELDS = ("actuator_gainprm", "actuator_biasprm", "actuator_forcerange",
                     "dof_frictionloss", "dof_armature", "geom_friction", "geom_solref",
                     "body_mass", "body_inertia", "jnt_range")
"""The model fields :class:`Randomizer` gives per-world values."""


def restitution_to_damping_ratio(e: np.ndarray) -> np.ndarray:
    """Contact damping ratio ζ of a mass–spring–damper contact with restitution e.

    e = exp(−ζπ / √(1 − ζ²)) ⇔ ζ = −ln e / √(π² + ln² e); e = 0 gives ζ = 1.
    """
    log_e = np.log(np.clip(e, 1e-9, 1.0))
    return np.where(e <= 1e-9, 1.0, -log_e / np.sqrt(np.pi**2 + log_e**2))


def _scaled(rng: np.random.Generator, lo_hi: tuple[float, float], scale: float,
            size, nominal: float = 1.0) -> np.ndarray:
    lo, hi = lo_hi
    lo, hi = nominal + scale * (lo - nominal), nominal + scale * (hi - nominal)
    return rng.uniform(lo, hi, size)


@dataclass
class Randomizer:
    """Writes randomised per-simulation model values for the episodes being reset.

    Args:
        model: the batch's nominal model.
        sims: the batch.
        cfg: the ranges.
    """

    model: mujoco.MjModel
    sims: PhysicsBatch
    cfg: DomainRandConfig

    def __post_init__(self) -> None:
        m, s = self.model, self.sims
        (self.gain, self.bias, self.force_range, self.friction_loss, self.armature,
         self.geom_friction, self.geom_solref, self.mass, self.inertia,
         self.jnt_range) = (s.expand(name) for name in RANDOMIZED_FIELDS)
        self.dofs = m.jnt_dofadr[1:1 + constants.NUM_JOINTS]
        self.kp0, self.kd0 = -m.actuator_biasprm[:, 1].copy(), -m.actuator_biasprm[:, 2].copy()
        self.range0 = m.jnt_range.copy()
        self.effort0 = m.actuator_forcerange.copy()
        self.nominal = {"armature": m.dof_armature.copy(), "mass": m.body_mass.copy(),
                        "inertia": m.body_inertia.copy(), "friction": m.geom_friction.copy(),
                        "solref": m.geom_solref.copy(), "frictionloss": m.dof_frictionloss.copy()}
        # PD gains, in the robot's actuator order, as the episode applies them.
        self.kp = np.tile(self.kp0, (s.nsim, 1))
        self.kd = np.tile(self.kd0, (s.nsim, 1))

    def randomize(self, ids: np.ndarray, rng: np.random.Generator, scale: float) -> None:
        """Samples new physical parameters for sims ``ids`` at DR strength ``scale``."""
        c, n, nu = self.cfg, len(ids), self.model.nu
        kp = self.kp0 * _scaled(rng, c.kp_scale, scale, (n, nu))
        kd = self.kd0 * _scaled(rng, c.kd_scale, scale, (n, nu))
        self.kp[ids], self.kd[ids] = kp, kd
        self.gain[ids, :, 0] = kp
        self.bias[ids, :, 1], self.bias[ids, :, 2] = -kp, -kd
        loss = self.nominal["frictionloss"][None].repeat(n, 0)
        lo, hi = c.joint_friction
        loss[:, self.dofs] = scale * rng.uniform(lo, hi, (n, len(self.dofs)))
        self.friction_loss[ids] = loss
        arm = self.nominal["armature"][None] * _scaled(rng, c.armature_scale, scale,
                                                       (n, self.model.nv))
        self.armature[ids] = arm
        mu0 = float(self.nominal["friction"][0, 0])
        mu = np.minimum(_scaled(rng, c.static_friction, scale, n, mu0),
                        _scaled(rng, c.dynamic_friction, scale, n, mu0))
        friction = self.nominal["friction"][None].repeat(n, 0)
        friction[:, :, 0] = mu[:, None]
        self.geom_friction[ids] = friction
        solref = self.nominal["solref"][None].repeat(n, 0)
        restitution = _scaled(rng, c.restitution, scale, n, 0.0)
        solref[:, :, 1] = restitution_to_damping_ratio(restitution)[:, None]
        self.geom_solref[ids] = solref
        self.mass[ids] = self.nominal["mass"] * _scaled(rng, c.mass_scale, scale,
                                                        (n, self.model.nbody))
        self.inertia[ids] = self.nominal["inertia"] * _scaled(
            rng, c.inertia_scale, scale, (n, self.model.nbody, 1))
        self.sims.set_const(ids)

    def set_limits(self, ids: np.ndarray, torque_scale: float, position_factor: float) -> None:
        """Effort limits × ``torque_scale``; joint ranges scaled about their middle."""
        self.force_range[ids] = self.effort0 * torque_scale
        mid = self.range0.mean(-1, keepdims=True)
        half = (self.range0[:, 1:2] - self.range0[:, 0:1]) / 2
        rng_ = np.concatenate([mid - half * position_factor, mid + half * position_factor], -1)
        rng_[0] = self.range0[0]
        self.jnt_range[ids] = rng_
