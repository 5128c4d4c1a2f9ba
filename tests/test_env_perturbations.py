"""Torso pushes and domain randomisation (paper §III-G) at full difficulty.

Pushes are checked against the momentum they give a free-floating robot (no gravity, no
ground): Δp_l = ∫F dt, since every other force on the robot is internal.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.domain_rand import restitution_to_damping_ratio
from hybrid_recovery.robot import constants

NUM_ENVS = 16


@pytest.fixture(scope="module")
def env():
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 11
    cfg.curriculum.enabled = False  # difficulty 1: full ranges, every push happens
    cfg.pushes.interval = (0.7, 0.9)  # longer than a push, so pushes never overlap
    cfg.pushes.fall_probability = 0.0
    return RecoveryEnv(cfg)


# ---------------------------------------------------------------- domain randomisation
def test_pd_gains_within_range_and_applied(env):
    r, c = env.randomizer, env.cfg.domain_rand
    kp, kd = r.kp / constants.KP, r.kd / constants.KD
    assert kp.min() >= c.kp_scale[0] and kp.max() <= c.kp_scale[1]
    assert kd.min() >= c.kd_scale[0] and kd.max() <= c.kd_scale[1]
    assert kp.std() > 0.1  # spread over the range, per env and joint
    for i in (0, NUM_ENVS - 1):  # what each simulation actually runs with
        model = env.sims.get_model(i)
        np.testing.assert_allclose(model.actuator_gainprm[:, 0], r.kp[i])
        np.testing.assert_allclose(-model.actuator_biasprm[:, 1], r.kp[i])
        np.testing.assert_allclose(-model.actuator_biasprm[:, 2], r.kd[i])


def test_joint_friction_and_armature_within_range(env):
    r, c = env.randomizer, env.cfg.domain_rand
    joint_dofs = env.dadr
    loss = r.friction_loss[:, joint_dofs]
    assert loss.min() >= c.joint_friction[0] and loss.max() <= c.joint_friction[1]
    assert (r.friction_loss[:, :6] == 0.0).all()  # not on the floating base
    nominal = env.model.dof_armature
    has = nominal > 0
    ratio = r.armature[:, has] / nominal[has]
    assert ratio.min() >= c.armature_scale[0] and ratio.max() <= c.armature_scale[1]
    assert (r.armature[:, ~has] == 0.0).all()


def test_contact_friction_and_restitution(env):
    r, c = env.randomizer, env.cfg.domain_rand
    mu = r.geom_friction[:, :, 0]
    assert (mu == mu[:, :1]).all()  # one coefficient per episode, every geom (floor too)
    assert mu.min() >= max(c.static_friction[0], c.dynamic_friction[0])
    assert mu.max() <= min(c.static_friction[1], c.dynamic_friction[1])
    nominal = env.model
    np.testing.assert_array_equal(r.geom_friction[:, :, 1:],
                                  np.broadcast_to(nominal.geom_friction[:, 1:], mu.shape + (2,)))
    zeta = r.geom_solref[:, :, 1]
    assert (zeta == zeta[:, :1]).all()
    np.testing.assert_array_equal(r.geom_solref[:, :, 0],
                                  np.broadcast_to(nominal.geom_solref[:, 0], zeta.shape))
    # ζ ∈ [ζ(e = 0.2), ζ(e = 0) = 1]; back to e with e = exp(−ζπ / √(1 − ζ²))
    e = np.exp(-zeta[:, 0] * np.pi / np.sqrt(np.maximum(1.0 - zeta[:, 0] ** 2, 1e-300)))
    assert e.min() >= c.restitution[0] and e.max() <= c.restitution[1] + 1e-9


def test_restitution_mapping_inverts():
    e = np.array([0.0, 0.01, 0.1, 0.2, 0.5, 0.9])
    zeta = restitution_to_damping_ratio(e)
    assert zeta[0] == 1.0 and np.all(np.diff(zeta) < 0)
    np.testing.assert_allclose(np.exp(-zeta[1:] * np.pi / np.sqrt(1 - zeta[1:] ** 2)), e[1:])
    assert restitution_to_damping_ratio(np.array([0.2]))[0] == pytest.approx(0.4559, abs=1e-4)


def test_mass_and_inertia_scales_within_range(env):
    r, c = env.randomizer, env.cfg.domain_rand
    bodies = slice(1, None)
    mass = r.mass[:, bodies] / env.model.body_mass[bodies]
    assert mass.min() >= c.mass_scale[0] and mass.max() <= c.mass_scale[1]
    inertia = r.inertia[:, bodies] / env.model.body_inertia[bodies]
    assert inertia.min() >= c.inertia_scale[0] and inertia.max() <= c.inertia_scale[1]
    # one factor per body: principal axes scaled together
    np.testing.assert_allclose(inertia, inertia[..., :1].repeat(3, -1))
    # what MuJoCo simulates: the per-simulation total mass
    np.testing.assert_allclose(env.sims.get_model(3).body_subtreemass[1], r.mass[3, 1:].sum())


def test_final_stage_limits(env):
    """curriculum.enabled=False: torque limits × 1, position limits × 0.9 about the middle."""
    r = env.randomizer
    np.testing.assert_allclose(r.force_range, np.broadcast_to(
        np.stack([-constants.EFFORT_LIMITS, constants.EFFORT_LIMITS], -1), r.force_range.shape))
    nominal = env.model.jnt_range[1:28]
    got = r.jnt_range[:, 1:28]
    np.testing.assert_allclose(got[..., 1] - got[..., 0],
                               np.broadcast_to(0.9 * (nominal[:, 1] - nominal[:, 0]),
                                               got.shape[:2]))
    np.testing.assert_allclose(got.mean(-1), np.broadcast_to(nominal.mean(-1), got.shape[:2]))


def test_difficulty_zero_is_nominal(env):
    r = env.randomizer
    ids = np.array([0, 1])
    saved = {name: getattr(r, name)[ids].copy() for name in
             ("kp", "kd", "friction_loss", "armature", "geom_friction", "geom_solref", "mass",
              "inertia")}
    r.randomize(ids, np.random.default_rng(0), 0.0)
    assert (r.friction_loss[ids] == 0.0).all()
    for got, nominal in ((r.kp, constants.KP), (r.kd, constants.KD),
                         (r.armature, env.model.dof_armature),
                         (r.geom_friction, env.model.geom_friction),
                         (r.geom_solref, env.model.geom_solref), (r.mass, env.model.body_mass),
                         (r.inertia, env.model.body_inertia)):
        np.testing.assert_allclose(got[ids], np.broadcast_to(nominal, got[ids].shape))
    for name, value in saved.items():  # restore the episode's values
        getattr(r, name)[ids] = value
    r.gain[ids, :, 0], r.bias[ids, :, 1], r.bias[ids, :, 2] = r.kp[ids], -r.kp[ids], -r.kd[ids]
    env.sims.set_const(ids)


# ---------------------------------------------------------------- pushes
def _segments(force: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
    """(start, steps, force) of each run of one constant non-zero force in (T, 3)."""
    out, start = [], None
    for t in range(len(force) + 1):
        same = start is not None and t < len(force) and np.array_equal(force[t], force[start])
        if start is not None and not same:
            out.append((start, t - start, force[start]))
            start = None
        if start is None and t < len(force) and np.any(force[t] != 0.0):
            start = t
    return out


def test_pushes_reach_the_torso_with_the_configured_impulse(env):
    p = env.cfg.pushes
    env.sims.expand("opt.gravity")[:] = 0.0  # free floating: only the push is external
    env.qpos[:, 2] += 5.0  # far above the ground
    env.qvel[:] = 0.0
    env.sims.forward()
    forces, momenta = [], []
    for _ in range(110):
        _, _, done, _ = env.step(torch.zeros(NUM_ENVS, env.num_actions))
        assert not done.any()
        forces.append(env.xfrc.copy())
        momenta.append(env._state["lin"].copy())
    xfrc, lin = np.stack(forces, 1), np.stack(momenta, 1)  # (N, T, nbody, 6), (N, T, 3)
    others = np.delete(xfrc, env.torso, axis=2)
    assert (others == 0.0).all() and (xfrc[:, :, env.torso, 3:] == 0.0).all()
    settle = 30  # the joints settle into the default pose first (no push before 0.7 s)
    count = 0
    for i in range(NUM_ENVS):
        force = xfrc[i, :, env.torso, :3]
        assert not force[:settle].any()
        for start, steps, f in _segments(force):
            count += 1
            magnitude = np.linalg.norm(f)
            assert f[2] == 0.0 and p.force[0] <= magnitude <= p.force[1]
            if start + steps < len(force):  # a whole push: duration within the range
                duration = steps * env.dt
                assert p.duration[0] - 1e-9 <= duration < p.duration[1] + env.dt
                assert p.force[0] * p.duration[0] <= magnitude * duration \
                    <= p.force[1] * (p.duration[1] + env.dt)
        # momentum change of the free-floating robot = ∫F dt (to the integrator's drift)
        impulse = force[settle + 1:].sum(0) * env.dt
        change = lin[i, -1] - lin[i, settle]
        np.testing.assert_allclose(change, impulse, atol=0.01 * np.linalg.norm(impulse) + 0.05)
    assert count >= NUM_ENVS


@pytest.mark.parametrize("torque_scale", [1.0, 10.0])
def test_torque_curriculum_reaches_the_joints(torque_scale):
    """The joint torque the actuators deliver (qfrc_actuator) is bounded by the scaled
    effort limit, and exceeds the hardware one when the exploration stage allows it."""
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 4, 1, 2
    cfg.pose_weights = {p: float(p == "squatting") for p in cfg.pose_weights}
    cfg.curriculum.stage1_poses = ("squatting",)
    cfg.curriculum.torque_scale_explore = torque_scale
    env = RecoveryEnv(cfg)
    dofs = env.model.jnt_dofadr[1:28]
    peak = np.zeros(27)
    for _ in range(5):  # zero action from a squat: the PD pulls hard towards standing
        env.step(torch.zeros(4, env.num_actions))
        tau = np.abs(env.sims.bind("qfrc_actuator")[:, dofs]).max(0)
        peak = np.maximum(peak, tau)
    limit = constants.EFFORT_LIMITS * torque_scale
    assert np.all(peak <= limit * (1 + 1e-9))
    knee = constants.JOINT_NAMES.index("left_knee_joint")
    if torque_scale > 1:
        assert peak[knee] > 1.5 * constants.EFFORT_LIMITS[knee]
    else:
        assert peak[knee] == pytest.approx(constants.EFFORT_LIMITS[knee])
