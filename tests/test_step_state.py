"""The MDP's per-step terms are written once, in the array API: from the same simulation
arrays, torch tensors (float64 and float32, on the CPU and on a GPU where there is one)
give what numpy gives, for every balance quantity, reward term, observation and
termination condition. The arrays are those of a real environment at full difficulty
after some steps (feet, knees, hands and the torso on the ground, resets among them)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from hybrid_recovery.bench.terms import env_arrays, step_terms
from hybrid_recovery.dynamics import net_centroidal_wrench
from hybrid_recovery.dynamics.capturability import capture_point
from hybrid_recovery.dynamics.support import signed_distance_batched, signed_distance_enumerated
from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.step_state import PRIVILEGED_DIM, read_step_state, reward_state
from hybrid_recovery.robot.constants import VELOCITY_LIMITS

DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])
F64_TOL = 1e-9
"""Absolute, every quantity in float64 (measured worst: 7e-15, the privileged observation)."""
F32_RTOL, F32_ATOL = 1e-4, 1e-3
"""float32 against float64: relative, and absolute [the quantity's units; forces in N
of ~600 and net forces of ~10⁴ N come within rtol; measured worst: net force 9e-4 N,
privileged observation 5e-5, actor observation 1.2e-7]."""


@pytest.fixture(scope="module")
def arrays():
    """A stepped env's simulation arrays and MDP inputs, as numpy."""
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 32, 1, 4
    cfg.curriculum.enabled = False  # every pose, full randomisation, pushes
    env = RecoveryEnv(cfg)
    gen = torch.Generator().manual_seed(1)
    for _ in range(12):
        env.step(torch.randn(cfg.num_envs, 27, generator=gen) * 0.5)
    return env_arrays(env, np.random.default_rng(2)), env._at, env.dt, env.cfg.rewards, \
        env.h_star


def _numpy(value) -> np.ndarray:
    return value.cpu().numpy() if isinstance(value, torch.Tensor) else np.asarray(value)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("dtype", [torch.float64, torch.float32])
def test_torch_tensors_give_the_numpy_terms(arrays, device, dtype):
    a, at, dt, rewards_cfg, h_star = arrays
    expected = step_terms(a, at, dt, rewards_cfg, h_star)
    tensors = {k: torch.as_tensor(v, device=device) for k, v in a.items()}
    tensors = {k: v.to(dtype) if v.is_floating_point() else v for k, v in tensors.items()}
    got = step_terms(tensors, at, dt, rewards_cfg, h_star)
    assert got.keys() == expected.keys()
    assert expected["privileged"].shape == (len(a["mass"]), PRIVILEGED_DIM)
    # the state is varied: contacts of several kinds, envs inside and outside their hulls
    assert (expected["state/d_com"] < 0).any() and (expected["state/d_com"] > 0).any()
    assert expected["state/support_contacts"].any() and expected["state/torso_force"].any()
    assert 0 < expected["upright"].sum() < len(a["mass"])
    for name, want in expected.items():
        value = got[name]
        assert isinstance(value, torch.Tensor) and value.device.type == device, name
        if want.dtype == bool:
            # a float32 height within rounding of the upright threshold may flip
            assert (_numpy(value) != want).mean() <= (0 if dtype == torch.float64 else 0.05), name
        elif dtype == torch.float64:
            np.testing.assert_allclose(_numpy(value), want, rtol=0, atol=F64_TOL, err_msg=name)
        else:
            np.testing.assert_allclose(_numpy(value), want, rtol=F32_RTOL, atol=F32_ATOL,
                                       err_msg=name)


def _point_sets(rng: np.random.Generator, n: int = 600, m: int = 26):
    point = rng.uniform(-1.0, 1.0, (n, 2))
    contacts = rng.uniform(-0.6, 0.6, (n, m, 3))
    mask = rng.random((n, m)) < rng.uniform(0.0, 0.5, (n, 1))
    contacts[:50, :, 1] = 0.2  # collinear: a segment, no inside
    contacts[50:100, :6] = contacts[50:100, :1]  # repeated points
    mask[100:120] = False  # no contact
    mask[120:140] = np.arange(m) == 3  # one point
    contacts[140:160, :, :2] = np.round(contacts[140:160, :, :2] * 4) / 4  # on a grid: ties
    return point, contacts, mask


@pytest.mark.parametrize("device", DEVICES)
def test_enumerated_hull_distance_equals_the_compiled_march(device):
    point, contacts, mask = _point_sets(np.random.default_rng(5))
    want = signed_distance_batched(point, contacts, mask)
    assert (want < 0).any() and (want > 0).any() and (want == 1.0).sum() >= 20
    np.testing.assert_allclose(signed_distance_enumerated(point, contacts, mask), want,
                               rtol=0, atol=1e-12)
    tensors = [torch.as_tensor(x, device=device) for x in (point, contacts, mask)]
    got = signed_distance_batched(*tensors)
    assert isinstance(got, torch.Tensor) and got.dtype == torch.float64
    np.testing.assert_allclose(_numpy(got), want, rtol=0, atol=1e-12)
    single = [x.float() if x.is_floating_point() else x for x in tensors]
    np.testing.assert_allclose(_numpy(signed_distance_batched(*single)), want, rtol=0, atol=1e-5)
    # one env with every slot active (no compaction), and a batch with no contact at all
    mask[0] = True
    np.testing.assert_allclose(signed_distance_enumerated(point, contacts, mask),
                               signed_distance_batched(point, contacts, mask), rtol=0, atol=1e-12)
    none = signed_distance_enumerated(*tensors[:2], torch.zeros_like(tensors[2]), no_contact=2.5)
    assert none.dtype == torch.float64 and (none == 2.5).all()


def test_enumerated_hull_distance_checks_shapes():
    with pytest.raises(ValueError, match="contact_points"):
        signed_distance_batched(torch.zeros(3, 2), torch.zeros(3, 4, 2), torch.zeros(3, 5,
                                                                                    dtype=bool))


def test_the_public_functions_still_take_lists_and_numbers():
    force, torque = net_centroidal_wrench([1.0, 2.0, 3.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0],
                                          [0.0, 0.0, 0.0], 0.5)
    np.testing.assert_array_equal(force, [2.0, 4.0, 6.0])
    np.testing.assert_array_equal(torque, [0.0, 0.0, 2.0])
    xi = capture_point([0.1, 0.2], (0.3, 0.0), 9.81, g=9.81)  # ω = 1
    assert isinstance(xi, np.ndarray) and xi.dtype == np.float64
    np.testing.assert_allclose(xi, [0.4, 0.2])
    np.testing.assert_allclose(capture_point([[0.1, 0.2]], [[0.3, 0.0]], [9.81], g=9.81),
                               [[0.4, 0.2]])


def test_the_speed_violation_is_each_joints_excess_over_its_velocity_limit(arrays):
    """Σ_j max(|q̇_j| / ω_max,j − 1, 0) from hand-set joint speeds: twice the limit counts 1,
    −1.5 times it 0.5 (either direction), half of it nothing."""
    a, at, dt, _, _ = arrays
    s = read_step_state(a["sensordata"], a["xmat"], a["qpos"], a["qvel"], a["actuator_force"],
                        a["mass"], a["prev_momentum"], a["prev_com_vel"], at, dt)
    limit = VELOCITY_LIMITS
    dq = np.zeros_like(s["dq"])
    dq[0, 3], dq[0, 20] = 2.0 * limit[3], -1.5 * limit[20]
    dq[1, :] = 0.5 * limit
    rs = reward_state(s | {"dq": dq}, a["joint_range"], limit, a["action"], a["last_action"],
                      a["terminated"])
    expected = np.zeros(len(dq))
    expected[0] = 1.5
    np.testing.assert_allclose(rs.speed_violation, expected)
