"""The two physics backends run one MDP: from the same states and actions, CPU MuJoCo
(``batch``, float64) and MuJoCo Warp on the CPU device (``warp``, float32) agree.

Both envs are built with the same seed, so their resets, randomised model values, pushes
and observation noise are drawn alike; they are then stepped with the same actions at
full difficulty (curriculum off: every start pose, full domain randomisation, pushes,
1× torque; 16 envs from all six poses). Measured worst cases over 4 control steps:
|Δqpos| 2.2e-6, |Δqvel| 2.5e-4 rad/s, reward terms 8e-7, observations 2.5e-4, hull
distances 5e-7 m, contact points 4e-7 m, contact forces 0.011 N. The tolerances below
are 4–50× those: float32 against float64, and Warp's solver tolerance (≥ 1e-6).

What it takes to agree (measured, see ``docs/backends.md``):

* the constraint solver run to convergence on both (``opt.iterations`` 100 here). The
  model caps Newton at 10 iterations; in the few contact states where that cap is met the
  two solvers stop at different iterates (Warp's tolerance is at least 1e-6, float32) and
  the envs drift apart by O(1) rad/s within 5 control steps;
* a plane–box contact keeps at most the box's 4 corners on the plane's side in C, every
  corner below the plane in MuJoCo Warp 4.0.0 (:func:`test_plane_box_contacts_differ`):
  a 3 cm foot box pressed deeper than its tilt allows (the 10× exploration torques of
  stage 1 slamming a squat) gets up to 8 contacts on Warp and the envs part.

The first call of MuJoCo Warp on a machine compiles its kernels (≈ 1 min on the CPU,
cached under ``~/.cache/warp``); run with ``-m warp`` or ``-m "not warp"`` to choose.
"""

from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest
import torch
from torch.utils._python_dispatch import TorchDispatchMode

pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed (the 'warp' extra)")

from hybrid_recovery.bench import run_env_bench  # noqa: E402
from hybrid_recovery.envs import RecoveryEnv, default_config  # noqa: E402
from hybrid_recovery.envs import recovery_env as recovery_env_module  # noqa: E402
from hybrid_recovery.envs.rewards import compute_rewards  # noqa: E402
from hybrid_recovery.envs.step_state import read_step_state  # noqa: E402
from hybrid_recovery.sim.scene import build_scene, read_contacts  # noqa: E402
from hybrid_recovery.sim.warp_batch import WarpBatch  # noqa: E402

pytestmark = pytest.mark.warp

NUM_ENVS, STEPS = 16, 4
QPOS_TOL, QVEL_TOL = 1e-4, 3e-3
"""[m or rad], [m/s or rad/s]."""
REWARD_TOL, OBS_TOL = 1e-5, 1e-3
"""Per reward term and step [reward units]; per observation entry [its units]."""
DISTANCE_TOL, FORCE_TOL = 1e-5, 0.1
"""Hull distances and contact points [m]; contact normal forces [N]."""


def _converged_scene(*args, **kwargs):
    model, layout = build_scene(*args, **kwargs)
    model.opt.iterations = 100
    return model, layout


@pytest.fixture(scope="module")
def runs():
    """Both backends stepped alike: per step, each env's physics, MDP state, observations,
    reward terms and contact slots."""
    mp = pytest.MonkeyPatch()
    mp.setattr(recovery_env_module, "build_scene", _converged_scene)
    envs = {}
    for backend in ("batch", "warp"):
        cfg = default_config()
        cfg.num_envs, cfg.num_threads, cfg.seed, cfg.backend = NUM_ENVS, 1, 1, backend
        cfg.curriculum.enabled = False
        envs[backend] = RecoveryEnv(cfg)
    mp.undo()
    gen = torch.Generator().manual_seed(0)
    out: dict[str, list[dict]] = {name: [] for name in envs}
    for _ in range(STEPS):
        actions = torch.randn(NUM_ENVS, 27, generator=gen) * 0.3
        for name, env in envs.items():
            obs, reward, done, _ = env.step(actions)
            _, parts = compute_rewards(env._reward_state(np.zeros(NUM_ENVS, dtype=bool)),
                                       env.cfg.rewards, env.h_star, env.dt)
            active, normal, points = read_contacts(env.sims.bind("sensordata"), env.layout)
            out[name].append({
                "qpos": env.qpos.astype(float), "qvel": env.qvel.astype(float),
                "state": {k: np.asarray(v, dtype=float) for k, v in env._state.items()},
                "policy": obs["policy"].numpy().copy(), "critic": obs["critic"].numpy().copy(),
                "reward": reward.numpy().copy(), "done": done.numpy().copy(),
                "parts": {k: np.asarray(v, dtype=float) for k, v in parts.items()},
                "active": active.copy(), "normal": normal.astype(float),
                "points": points.astype(float)})
    return envs, out


def _worst(runs, key):
    _, out = runs
    return max(float(np.abs(a[key] - w[key]).max()) for a, w in zip(out["batch"], out["warp"],
                                                                   strict=True))


def test_same_starts_and_randomisation(runs):
    envs, _ = runs
    batch, warp = envs["batch"], envs["warp"]
    assert (batch.start_pose == warp.start_pose).all()
    assert (batch.delay_steps == warp.delay_steps).all()
    assert len(set(batch.start_pose)) >= 4  # several poses, lying ones among them
    np.testing.assert_allclose(warp.randomizer.mass, batch.randomizer.mass, rtol=1e-6)
    np.testing.assert_allclose(warp.randomizer.gain, batch.randomizer.gain, rtol=1e-6)
    np.testing.assert_allclose(warp.randomizer.geom_friction, batch.randomizer.geom_friction,
                               rtol=1e-6)


def test_physics_state_agrees(runs):
    assert _worst(runs, "qpos") < QPOS_TOL
    assert _worst(runs, "qvel") < QVEL_TOL


def test_every_reward_term_agrees(runs):
    _, out = runs
    for a, w in zip(out["batch"], out["warp"], strict=True):
        assert set(a["parts"]) == set(w["parts"])
        for name in a["parts"]:
            assert np.abs(a["parts"][name] - w["parts"][name]).max() < REWARD_TOL, name
        assert (a["done"] == w["done"]).all()
    assert _worst(runs, "reward") < REWARD_TOL


def test_every_observation_term_agrees(runs):
    """Actor (noisy, the same noise draws) and critic observations (with the privileged
    momenta and the CoM acceleration, a finite difference over Δt), entry by entry."""
    _, out = runs
    for a, w in zip(out["batch"], out["warp"], strict=True):
        np.testing.assert_allclose(w["policy"], a["policy"], atol=OBS_TOL, rtol=0)
        np.testing.assert_allclose(w["critic"], a["critic"], atol=OBS_TOL, rtol=0)


def test_support_hulls_and_contacts_agree(runs):
    """The contact slots the rewards read: as many slots active per group, the same
    normal forces and points; the support-hull distances of CoM and capture point."""
    envs, out = runs
    for a, w in zip(out["batch"], out["warp"], strict=True):
        for group, slots in envs["batch"].layout.group_slots.items():
            assert (a["active"][:, slots].sum(1) == w["active"][:, slots].sum(1)).all(), group
            force_a = a["normal"][:, slots].sum(1)
            force_w = w["normal"][:, slots].sum(1)
            assert np.abs(force_a - force_w).max() < FORCE_TOL, group
        both = a["active"] & w["active"]
        assert np.abs(a["points"] - w["points"])[both].max(initial=0.0) < DISTANCE_TOL
        for key in ("d_com", "d_cp"):
            assert np.abs(a["state"][key] - w["state"][key]).max() < DISTANCE_TOL, key
        for key in ("torso_force", "foot_force"):
            assert np.abs(a["state"][key] - w["state"][key]).max() < FORCE_TOL, key
        assert (a["state"]["support_contacts"] == w["state"]["support_contacts"]).all()
    assert any(o["active"].any() for o in out["warp"])  # contacts were there to compare


def test_env_arrays_are_views_of_warp_memory(runs):
    envs, _ = runs
    env = envs["warp"]
    sims = env.sims
    assert isinstance(sims, WarpBatch)
    assert np.shares_memory(env.qpos, sims.d.qpos.numpy())
    assert np.shares_memory(env.xmat, sims.d.xmat.numpy())
    assert np.shares_memory(env.randomizer.mass, sims.m.body_mass.numpy())
    saved = env.qvel[0, 0].copy()
    env.qvel[0, 0] = 0.25
    assert sims.d.qvel.numpy()[0, 0] == np.float32(0.25)
    env.qvel[0, 0] = saved


def test_the_step_terms_read_warp_memory_through_zero_copy_torch_views(runs):
    """The MDP's per-step terms on torch tensors that are Warp's own arrays
    (``WarpBatch.tensor``, no host copy: what a GPU run reads) equal those on the numpy
    views of the same memory."""
    envs, _ = runs
    env = envs["warp"]
    names = ("sensordata", "xmat", "qpos", "qvel", "actuator_force")
    views = {name: env.sims.tensor(name) for name in names}
    for name, view in views.items():
        host = env.sims.bind(name)
        assert view.data_ptr() == host.ctypes.data and view.shape == host.shape, name
        np.testing.assert_array_equal(view.numpy(), host)
    rest = (env.randomizer.mass[:, 1:].sum(1), env._to_host(env.prev_momentum),
            env._to_host(env.prev_com_vel))
    want = read_step_state(*(env.sims.bind(name) for name in names), *rest, env._at, env.dt)
    got = read_step_state(*views.values(), *(torch.from_numpy(x) for x in rest), env._at,
                          env.dt)
    assert got.keys() == want.keys()
    for key, value in want.items():
        assert isinstance(got[key], torch.Tensor), key
        # numpy takes ξ and the hull distances in float64, the tensors in Warp's float32
        # (measured worst: d_cp 3.8e-8 m, every other quantity identical)
        np.testing.assert_allclose(got[key].numpy(), value, rtol=1e-6, atol=1e-6, err_msg=key)
    with pytest.raises(KeyError, match="no field"):
        env.sims.tensor("not_a_field")


def _batch_run(host_copies: bool) -> dict[str, np.ndarray]:
    model, _ = build_scene()
    sims = WarpBatch(model, 3, "cpu", expand=("body_mass",), host_copies=host_copies)
    qpos, qvel, ctrl = sims.bind("qpos"), sims.bind("qvel"), sims.bind("ctrl")
    sensordata = sims.bind("sensordata")
    qpos[:, 2] = [1.2, 1.4, 1.6]
    qvel[:, 0] = [0.0, 0.5, -0.5]
    ctrl[:] = 0.1
    sims.expand("body_mass")[1] *= 1.5
    sims.set_const()
    sims.forward()
    sims.step(nstep=3, stage=mujoco.mjtStage.mjSTAGE_VEL)
    stepped = sims.tensor("qpos").numpy().copy()  # the device holds the state
    sims.download()
    before = sensordata.copy()
    qpos[0, 0] = 0.3  # world 0 moves; worlds 1, 2 keep their derived fields
    sims.forward([0])
    return {"qpos": qpos.copy(), "qvel": qvel.copy(), "sensordata": sensordata.copy(),
            "before": before, "stepped": stepped,
            "device": sims.tensor("sensordata").numpy().copy(),
            "subtreemass": sims.m.body_subtreemass.numpy()[:, 0].copy()}


def test_host_copies_give_the_same_results_as_views():
    """``host_copies=True`` is the ``cuda`` device's path (host copies synchronised by
    rows around the calls on some worlds, nothing moved by a step), run here on the CPU
    device: bit-identical results to zero-copy views."""
    views, copies = _batch_run(False), _batch_run(True)
    for key in views:
        np.testing.assert_array_equal(copies[key], views[key], err_msg=key)
    np.testing.assert_array_equal(copies["device"], copies["sensordata"])
    # forward([0]) changed world 0's sensors only
    assert not np.array_equal(views["sensordata"][0], views["before"][0])
    np.testing.assert_array_equal(views["sensordata"][1:], views["before"][1:])
    # set_const derived each world's own total mass: world 1's bodies are 1.5× heavier
    total = views["subtreemass"]
    assert total[1] == pytest.approx(1.5 * total[0], rel=1e-6)
    assert total[2] == pytest.approx(total[0], rel=1e-6)


@pytest.mark.parametrize("host_copies", [False, True])
def test_a_reset_of_some_worlds_leaves_every_field_of_the_others(host_copies):
    """``reset(ids, stage=NONE)`` runs MuJoCo Warp's masked reset (nothing to put back):
    every per-world data field of the other worlds is as it was, the reset worlds are at
    the model's defaults, on views and through host copies alike."""
    import warp as wp

    model, _ = build_scene()
    sims = WarpBatch(model, 4, "cpu", host_copies=host_copies)
    qpos = sims.bind("qpos")
    qpos[:, 2] += np.arange(4, dtype=np.float32) * 0.1
    sims.bind("ctrl")[:] = 0.2
    sims.forward()
    sims.step(nstep=3, stage=mujoco.mjtStage.mjSTAGE_VEL)
    sims.download()

    def per_world() -> dict[str, np.ndarray]:
        return {name: array.numpy().copy() for name in dir(sims.d)
                if isinstance(array := getattr(sims.d, name), wp.array)
                and array.shape and array.shape[0] == 4}

    before = per_world()
    sims.reset([1, 3], stage=mujoco.mjtStage.mjSTAGE_NONE)
    after = per_world()
    assert len(before) > 100
    for name in before:
        np.testing.assert_array_equal(after[name][[0, 2]], before[name][[0, 2]], err_msg=name)
    np.testing.assert_array_equal(after["qpos"][[1, 3]],
                                  np.tile(model.qpos0.astype(np.float32), (2, 1)))
    np.testing.assert_array_equal(qpos[[1, 3]], after["qpos"][[1, 3]])  # host rows too
    np.testing.assert_array_equal(after["qvel"][[1, 3]], 0.0)


@pytest.mark.parametrize("host_copies", [False, True])
def test_a_reset_with_its_stages_puts_the_others_bound_rows_back(host_copies):
    """``reset(ids)`` computing the stages runs them on every world: the other worlds'
    bound fields (acceleration-stage sensors included) are put back as they were."""
    model, _ = build_scene()
    sims = WarpBatch(model, 4, "cpu", host_copies=host_copies)
    bound = {name: sims.bind(name) for name in ("qpos", "qvel", "ctrl", "sensordata", "xmat")}
    bound["qpos"][:, 2] += np.arange(4, dtype=np.float32) * 0.1
    bound["ctrl"][:] = 0.2
    sims.forward()
    sims.step(nstep=3, stage=mujoco.mjtStage.mjSTAGE_VEL)
    sims.download()
    before = {name: sims.tensor(name).numpy().copy() for name in bound}
    sims.reset([1, 3])
    for name in bound:
        after = sims.tensor(name).numpy()
        np.testing.assert_array_equal(after[[0, 2]], before[name][[0, 2]], err_msg=name)
        np.testing.assert_array_equal(bound[name], after, err_msg=name)
    assert not np.array_equal(sims.tensor("sensordata").numpy()[1], before["sensordata"][1])


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_on_a_gpu_a_captured_step_is_the_launched_one():
    """The calls as CUDA graphs (the default on a GPU) and kernel by kernel, with the
    joint targets written through torch views between steps (the same stream orders
    them) and a forward and a reset on some worlds: the same trajectories."""
    model, _ = build_scene()
    trajectories = []
    for graphs in (False, True):
        sims = WarpBatch(model, 64, "cuda", graphs=graphs)
        sims.bind("qpos")[:, 2] += np.linspace(0.0, 0.5, 64, dtype=np.float32)
        sims.forward()
        ctrl, qpos = sims.tensor("ctrl"), sims.tensor("qpos")
        states = []
        for k in range(6):
            ctrl[:] = 0.05 * k
            sims.step(nstep=4, stage=mujoco.mjtStage.mjSTAGE_VEL)
            states.append(qpos.cpu().numpy().copy())
            if k == 2:  # a host write, a forward and a reset on some worlds (captured too)
                sims.download([3])
                sims.bind("qpos")[3, 2] += 0.1
                sims.forward([3])
                sims.reset([0, 5])
                states.append(qpos.cpu().numpy().copy())
        trajectories.append(np.stack(states))
    np.testing.assert_allclose(trajectories[1], trajectories[0], atol=1e-5, rtol=0)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_on_a_gpu_the_mdp_is_the_cpu_devices(monkeypatch):
    """The whole MDP on a GPU (the step on the device's arrays, resets through host copies
    synchronised by rows, CUDA graphs) and on the CPU device, from the same seed and
    actions at full difficulty with timeouts and resets: the same starts, dones and
    pushes; observations and rewards within the parity tolerances (float32 on both,
    different hardware)."""
    monkeypatch.setattr(recovery_env_module, "build_scene", _converged_scene)
    runs = {}
    for device in ("cpu", "cuda"):
        cfg = default_config()
        cfg.num_envs, cfg.num_threads, cfg.seed = NUM_ENVS, 1, 1
        cfg.backend, cfg.device = "warp", device
        cfg.curriculum.enabled = False
        cfg.episode_length_s = 0.06  # timeouts and resets within the run
        env = RecoveryEnv(cfg, device=device)
        gen = torch.Generator().manual_seed(0)
        steps = []
        for _ in range(STEPS + 2):
            obs, reward, done, _ = env.step(torch.randn(NUM_ENVS, 27, generator=gen) * 0.3)
            steps.append({"policy": obs["policy"].cpu().numpy(),
                          "critic": obs["critic"].cpu().numpy(),
                          "reward": reward.cpu().numpy(), "done": done.cpu().numpy(),
                          "push": env.applied_push(0)})
        runs[device] = (env.start_pose.copy(), steps)
    (poses_cpu, cpu), (poses_gpu, gpu) = runs["cpu"], runs["cuda"]
    np.testing.assert_array_equal(poses_gpu, poses_cpu)
    assert any(step["done"].any() for step in cpu)
    for a, b in zip(cpu, gpu, strict=True):
        np.testing.assert_array_equal(b["done"], a["done"])
        np.testing.assert_array_equal(b["push"], a["push"])
        np.testing.assert_allclose(b["policy"], a["policy"], atol=OBS_TOL, rtol=0)
        np.testing.assert_allclose(b["critic"], a["critic"], atol=OBS_TOL, rtol=0)
        np.testing.assert_allclose(b["reward"], a["reward"], atol=REWARD_TOL, rtol=0)


def test_plane_box_contacts_differ():
    """A known difference of the engines (MuJoCo 4.0 vs MuJoCo Warp 4.0.0): a box tilted
    and pressed into the floor so that corners of its upper half are below it gets at
    most 4 contacts in C (lower-half corners only) and one per corner below in Warp."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    body = spec.worldbody.add_body(pos=[0, 0, 0.0])
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.1275, 0.0425, 0.015])
    model = spec.compile()
    data = mujoco.MjData(model)
    pitch, z = 0.3, -0.03  # toe down 0.3 rad, centre 3 cm below the floor
    data.qpos[:7] = [0, 0, z, np.cos(pitch / 2), 0, np.sin(pitch / 2), 0]
    mujoco.mj_forward(model, data)
    sims = WarpBatch(model, 1, "cpu")
    sims.bind("qpos")[0] = data.qpos
    sims.forward()
    below = int(np.sum(_box_corner_heights(pitch, z) < 0))
    assert data.ncon == 4
    assert int(sims.d.nacon.numpy()[0]) == below > 4


def _box_corner_heights(pitch: float, z: float) -> np.ndarray:
    half = np.array([0.1275, 0.0425, 0.015])
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    c, s = np.cos(pitch), np.sin(pitch)
    rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return z + (signs * half) @ rot[2]


def test_env_bench_prints_the_same_json_on_both_backends():
    """``bench env --backend warp``: the same figures, the physics-only rate replayed on
    Warp's worlds."""
    lines = {backend: json.loads(run_env_bench(n=2, repeat=1, steps=3, threads=1,
                                               backend=backend).json_line())
             for backend in ("batch", "warp")}
    assert set(lines["warp"]) == set(lines["batch"])
    assert set(lines["warp"]["ms_per_step"]) == set(lines["batch"]["ms_per_step"])
    assert lines["warp"]["backend"] == "warp" and lines["warp"]["device"] == "cpu"
    assert lines["warp"]["physics_steps_per_s"] > 0 and lines["warp"]["env_steps_per_s"] > 0


def test_train_bench_prints_the_same_json_on_both_backends():
    """``bench train --backend warp``: PPO iterations on Warp's worlds, the same figures."""
    from hybrid_recovery.bench import run_train_bench

    lines = {backend: json.loads(run_train_bench(n=4, repeat=1, threads=1, backend=backend,
                                                 overrides={"ppo.num_learning_epochs": 1})
                                 .json_line())
             for backend in ("batch", "warp")}
    assert set(lines["warp"]) == set(lines["batch"])
    assert set(lines["warp"]["s_per_iteration"]) == set(lines["batch"]["s_per_iteration"])
    assert lines["warp"]["settings"]["backend"] == "warp"
    assert lines["warp"]["env_steps_per_s"] > 0


def test_cuda_without_a_gpu_is_refused_by_name():
    import warp as wp

    from hybrid_recovery.sim.backend import check_backend

    if wp.get_cuda_device_count() > 0:
        pytest.skip("a CUDA GPU is present")
    with pytest.raises(ValueError) as err:
        check_backend("warp", "cuda")
    assert str(err.value) == "device 'cuda' needs a CUDA GPU, and Warp finds none"


def test_warp_batch_refuses_what_it_cannot_do_by_name():
    model, _ = build_scene()
    with pytest.raises(ValueError) as err:
        WarpBatch(model, 0)
    assert str(err.value) == "WarpBatch needs nsim >= 1, got 0"
    sims = WarpBatch(model, 2, "cpu", expand=("body_mass",))
    with pytest.raises(ValueError) as err:
        sims.expand("geom_friction")
    assert str(err.value) == ("model field 'geom_friction' was not expanded: give it in "
                              "WarpBatch(expand=...) (expanded: ['body_mass'])")
    with pytest.raises(KeyError) as err:
        sims.bind("qpos_typo")
    assert err.value.args[0] == "MuJoCo Warp data has no field 'qpos_typo'"
    with pytest.raises(ValueError) as err:
        sims.step([1])
    assert str(err.value) == "WarpBatch steps every world: ids must be None or all worlds"


class _Transfers(TorchDispatchMode):
    """Counts what would cross between a GPU and the host: copies to the host
    (``Tensor.cpu``), copies to the device (``Tensor.to`` or ``torch.as_tensor`` with a
    device) and scalar reads of a tensor (``int``, ``bool``, ``item``: the dispatcher's
    ``_local_scalar_dense``). On the CPU device the copies are no-ops, but the calls are
    the ones a GPU would make."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        super().__init__()
        self.counts = {"to_host": 0, "to_device": 0, "scalar": 0}
        cpu, to, as_tensor = torch.Tensor.cpu, torch.Tensor.to, torch.as_tensor

        def counted_cpu(tensor, *args, **kwargs):
            self.counts["to_host"] += 1
            return cpu(tensor, *args, **kwargs)

        def counted_to(tensor, *args, **kwargs):
            if "device" in kwargs or any(isinstance(a, str | torch.device) for a in args):
                self.counts["to_device"] += 1
            return to(tensor, *args, **kwargs)

        def counted_as_tensor(*args, **kwargs):
            if "device" in kwargs:
                self.counts["to_device"] += 1
            return as_tensor(*args, **kwargs)

        monkeypatch.setattr(torch.Tensor, "cpu", counted_cpu)
        monkeypatch.setattr(torch.Tensor, "to", counted_to)
        monkeypatch.setattr(torch, "as_tensor", counted_as_tensor)

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        if func.overloadpacket is torch.ops.aten._local_scalar_dense:
            self.counts["scalar"] += 1
        return func(*args, **(kwargs or {}))


def test_a_row_sync_moves_each_dtype_once(monkeypatch):
    """With host copies (a GPU's path), a ``forward`` of some worlds moves their rows of
    every bound and expanded field (float32) as one array each way, with one transfer of
    the indices: 3 transfers, however many fields are bound."""
    model, _ = build_scene()
    sims = WarpBatch(model, 4, "cpu", expand=("body_mass", "geom_friction"),
                     host_copies=True)
    for name in ("qpos", "qvel", "ctrl", "xfrc_applied", "xmat", "sensordata", "history"):
        sims.bind(name)
    sims.expand("body_mass")
    sims.expand("geom_friction")
    sims.forward()
    transfers = _Transfers(monkeypatch)
    with transfers:
        sims.forward([1, 3])
    assert transfers.counts == {"to_host": 1, "to_device": 2, "scalar": 0}


def test_a_control_step_reads_the_device_seven_times(monkeypatch):
    """The env's control step on device arrays (host copies on the CPU device): without a
    reset it reads the device 7 times — the NaN flags of actions and states together,
    the solver's overflow counts, the host's bookkeeping quantities as one array, the
    reward terms, and three scalars (the active contacts of the two hulls, the capture
    point's height check) — and a reset adds a fixed number, not one per field."""
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed, cfg.backend = 4, 1, 2, "warp"
    cfg.curriculum.enabled = False

    class Copied(WarpBatch):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs, host_copies=True)

    monkeypatch.setattr(recovery_env_module, "physics_batch",
                        lambda model, n, *args, expand=(), **kwargs:
                        Copied(model, n, "cpu", expand=expand))
    env = RecoveryEnv(cfg)
    actions = torch.zeros(4, 27)
    env.step(actions)
    transfers = _Transfers(monkeypatch)
    with transfers:
        _, _, done, _ = env.step(actions)
    assert not done.any()
    assert transfers.counts["to_host"] + transfers.counts["scalar"] == 7
    env.episode_length_buf[:2] = env.max_episode_length  # two timeouts at the next step
    with _Transfers(monkeypatch) as resetting:
        _, _, done, _ = env.step(actions)
    assert done.tolist() == [True, True, False, False]
    reads = resetting.counts["to_host"] + resetting.counts["scalar"]
    # the reset: reset, seating, set_const and forward each read their rows once; the
    # new episodes' state is read again (the host quantities and the scalars above)
    assert reads == 7 + 4 + 4, resetting.counts


def test_the_whole_mdp_through_host_copies_is_bit_identical(monkeypatch):
    """The ``cuda`` path under the whole MDP — the steps on the device's arrays, the resets
    (seating, randomisation, delays) on host copies synchronised by rows — run on the CPU
    device: the same observations, rewards and dones as through zero-copy views, bit for
    bit."""
    from hybrid_recovery.sim import warp_batch

    class Copied(warp_batch.WarpBatch):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs, host_copies=True)

    results = []
    for copies in (False, True):
        if copies:
            monkeypatch.setattr(warp_batch, "WarpBatch", Copied)
        cfg = default_config()
        cfg.num_envs, cfg.num_threads, cfg.seed, cfg.backend = 4, 1, 2, "warp"
        cfg.curriculum.enabled = False
        cfg.episode_length_s = 0.06  # a timeout reset within the run
        env = RecoveryEnv(cfg)
        assert env.sims.host_copies is copies
        gen = torch.Generator().manual_seed(1)
        steps = []
        for _ in range(8):
            obs, reward, done, extras = env.step(torch.randn(4, 27, generator=gen) * 0.3)
            steps.append((obs, reward, done, env.applied_push(1)))
            if not copies:  # the host's arrays are the device's
                np.testing.assert_array_equal(steps[-1][3], env.xfrc[1, env.torso, :3])
        results.append(steps)
    for (obs_a, rew_a, done_a, push_a), (obs_b, rew_b, done_b, push_b) in zip(*results,
                                                                               strict=True):
        np.testing.assert_array_equal(push_a, push_b)
        assert torch.equal(obs_a["critic"], obs_b["critic"])
        assert torch.equal(obs_a["policy"], obs_b["policy"])
        assert torch.equal(rew_a, rew_b) and torch.equal(done_a, done_b)
    assert any(bool(done.any()) for _, _, done, _ in results[0])
