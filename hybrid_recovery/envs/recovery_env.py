"""RecoveryEnv: N H1-2 robots in a persistent physics batch, the paper's MDP.

One control step (50 Hz) = ``decimation`` physics substeps; within it each robot's PD
targets follow its per-episode actuation delay. Balance inputs are MuJoCo sensors (see
:mod:`hybrid_recovery.sim.scene`) turned into balance quantities by
:mod:`hybrid_recovery.envs.step_state`. The batch is CPU MuJoCo's ``mujoco.batch.Batch``
or MuJoCo Warp (``EnvConfig.backend``, :mod:`hybrid_recovery.sim.backend`); the MDP is
the same code on both. Each control step's work is vectorised over the simulation's own
arrays (:attr:`RecoveryEnv._sim`: numpy for CPU MuJoCo, torch views of MuJoCo Warp's on
its device, where the state stays); the host keeps the bookkeeping (pushes, stuck-low,
standing times, curricula, windows) and the resets, host code over the reset rows.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, cast

import mujoco
import numpy as np
import torch
from array_api_compat import array_namespace
from mujoco import batch as mjbatch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.envs.assist import Assist
from hybrid_recovery.envs.config import EnvConfig, default_config
from hybrid_recovery.envs.curriculum import Curriculum
from hybrid_recovery.envs.domain_rand import RANDOMIZED_FIELDS, Randomizer
from hybrid_recovery.envs.motors import DcMotors
from hybrid_recovery.envs.pose_bridge import PoseBridge
from hybrid_recovery.envs.pushes import Pushes
from hybrid_recovery.envs.rewards import RewardState, compute_rewards
from hybrid_recovery.envs.rise_starts import RiseStarts, turned
from hybrid_recovery.envs.step_state import (
    StepIndices,
    privileged_observation,
    read_step_state,
    reward_state,
)
from hybrid_recovery.envs.terminations import TERMINATIONS, StuckLow, success_step
from hybrid_recovery.envs.terrain_tiles import TerrainTiles, rough_terrains
from hybrid_recovery.observation.actor import actor_observation, noise_halfwidths
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.action import clip_action, joint_targets
from hybrid_recovery.robot.mjcf import default_qpos
from hybrid_recovery.sim.backend import check_backend, physics_batch
from hybrid_recovery.sim.divergence import MAX_SPEED, clock_broken
from hybrid_recovery.sim.initial_states import (
    POSES,
    perturb_start,
    seat_on_ground,
    settle_pool,
)
from hybrid_recovery.sim.scene import build_scene

if TYPE_CHECKING:
    from hybrid_recovery.sim.warp_batch import WarpBatch

_HARD_POSES = ("sitting", "supine", "prone")

HOST_STATE = ("mass", "gravity_b", "height", "height_vel", "torso_force")
"""The step's quantities the host's bookkeeping reads (terminations, standing times,
assistance), downloaded each step where the simulation is on a GPU."""


class RecoveryEnv(VecEnv):
    """Batched fall-recovery environment for rsl-rl (``rsl_rl.env.VecEnv``).

    Observation groups: ``policy`` (87, noisy proprioception) and ``critic`` (87 clean
    + 17 privileged balance quantities, or 87 with ``privileged_critic=False``).

    Args:
        cfg: Environment configuration; None for :func:`default_config`.
        device: torch device of the returned tensors.
        local_rank: the process's GPU (``cuda:<local_rank>``) for the ``warp`` backend on
            ``cuda`` under ``torchrun``.

    Raises:
        ValueError, ImportError: a bad ``backend``/``device`` choice
            (:func:`~hybrid_recovery.sim.backend.check_backend`).
    """

    def __init__(self, cfg: EnvConfig | None = None, device: str = "cpu",
                 local_rank: int = 0) -> None:
        self.cfg = cfg = cfg or default_config()
        if cfg.num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {cfg.num_envs}")
        check_backend(cfg.backend, cfg.device)
        self.device = device
        self.num_envs, self.num_actions = cfg.num_envs, constants.NUM_JOINTS
        self.dt = cfg.physics_dt * cfg.decimation
        self.max_episode_length = int(math.ceil(cfg.episode_length_s / self.dt))
        self.rng = np.random.default_rng(cfg.seed)
        delay = np.round(np.asarray(cfg.delay_range) / cfg.physics_dt).astype(int)
        self._delay_steps = (int(delay[0]), int(delay[1]))
        terrain = cfg.terrain.enabled
        self.model, self.layout = build_scene(
            cfg.model_path, cfg.physics_dt, delay_samples=int(delay[1]) + 2,
            rough=rough_terrains(cfg.terrain) if terrain else (),
            step_height=cfg.terrain.max_step if terrain else 0.0)
        n, m = cfg.num_envs, self.model
        self.rises = RiseStarts(cfg.rises, m.nq, m.nv)  # its files checked before the work
        self.sims = physics_batch(m, n, cfg.num_threads, cfg.backend, cfg.device,
                                  expand=(*RANDOMIZED_FIELDS, "actuator_delay",
                                          *(("geom_quat", "geom_pos") if terrain else ())),
                                  local_rank=local_rank)
        b = self.sims.bind
        self.qpos, self.qvel, self.ctrl = b("qpos"), b("qvel"), b("ctrl")
        self.xfrc, self.xmat = b("xfrc_applied"), b("xmat")
        """The simulation's arrays as the resets (host code over rows) read and write them;
        each control step reads and writes :attr:`_sim`."""
        self.history, self.actuator_delay = b("history"), self.sims.expand("actuator_delay")
        ns = int(m.actuator_history[0, 0])  # per actuator: 2 + ns times + ns values
        self._history_values = m.actuator_historyadr[:, None] + 2 + ns + np.arange(ns)
        self.delay_steps = np.zeros(n, dtype=int)
        """Per-episode actuation delay [substeps]."""
        self.qadr = m.jnt_qposadr[1:1 + constants.NUM_JOINTS]
        self.dadr = m.jnt_dofadr[1:1 + constants.NUM_JOINTS]
        self.torso = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, constants.TORSO_BODY)
        self.feet = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
                              for name in constants.FOOT_BODIES])
        self.knees = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
                               for name in constants.KNEE_BODIES])
        self.randomizer = Randomizer(m, self.sims, cfg.domain_rand)
        self.motors = DcMotors(self.randomizer.force_range, self.qvel, m,
                               cfg.actuator_saturation) if cfg.actuator == "dc" else None
        """The DC motor model (``cfg.actuator == "dc"``), else None: ideal motors."""
        self.terrain = TerrainTiles(m, self.sims, cfg.terrain) if terrain else None
        """Each episode's ground (``cfg.terrain.enabled``), else None: flat ground."""
        self._device: torch.device | None = None if isinstance(self.sims, mjbatch.Batch) \
            else cast("WarpBatch", self.sims).torch_device
        """The simulation's torch device (None: CPU MuJoCo's numpy arrays)."""
        self._sim = self._step_arrays()
        self._xp = array_namespace(self._sim["qpos"])
        self.curriculum = Curriculum(cfg.curriculum)
        self.assist = Assist(cfg.assist, cfg.curriculum.window, cfg.curriculum.advance_success)
        self.pushes = Pushes(cfg.pushes, n, self.dt)
        self.stuck = StuckLow(n, cfg.stuck_time, cfg.stuck_rise, self.dt)
        self.pool = settle_pool(m, per_pose=32, rng=self.rng, nthread=cfg.num_threads)
        # a pose with recorded rises starts along them, not from its bridge's blends
        self.bridge = PoseBridge(dataclasses.replace(cfg.bridge, pairs=tuple(
            pair for pair in cfg.bridge.pairs if tuple(pair)[-1] not in self.rises.poses)))
        self.bridge_pool = settle_pool(m, per_pose=32, rng=self.rng, nthread=cfg.num_threads,
                                       library=self.bridge.poses()) if self.bridge.targets else {}
        """Settled blends of the start-pose bridges (:mod:`~.pose_bridge`), by level name."""
        self.noise = noise_halfwidths(cfg.noise.ang_vel, cfg.noise.gravity, cfg.noise.joint_pos,
                                      cfg.noise.joint_vel)
        self.h_star = cfg.rewards.height_target or float(self._com_height(default_qpos(m)))
        self.action = self._to_sim(np.zeros((n, self.num_actions)))
        self.last_action = self._xp.zeros_like(self.action)
        self.velocity_limit = self._to_sim(constants.VELOCITY_LIMITS.copy())
        """ω_max of the joints in action order (27,) [rad/s]."""
        self.episode_length_buf = torch.zeros(n, dtype=torch.long)
        self.prev_momentum = self._to_sim(np.zeros((n, 6)))
        self.prev_com_vel = self._to_sim(np.zeros((n, 3)))
        self.upright_time = np.zeros(n)
        self.succeeded = np.zeros(n, dtype=bool)
        self.up_time = np.zeros(n)
        self.stood_up = np.zeros(n, dtype=bool)
        self.start_pose = np.zeros(n, dtype=int)
        """Index into ``POSES`` of each env's episode start."""
        self.start_level = np.full(n, -1)
        """Bridge or rise level of each episode's start (−1: the pose's own settled
        start), (N,) int."""
        self._start_counted = np.zeros(n, dtype=bool)
        self._window_counted = np.zeros(n, dtype=bool)
        """Episodes whose outcome the bridges and rises / the curriculum and assistance
        windows have counted (:meth:`_count_starts`, :meth:`_count_windows`), (N,) bool."""
        self._pose_names = np.asarray(POSES)
        if cfg.curriculum.advance_on not in ("stood_up", "success"):
            raise ValueError(f"curriculum.advance_on must be 'stood_up' or 'success', got "
                             f"'{cfg.curriculum.advance_on}'")
        for key, named in (("curriculum.advance_poses", cfg.curriculum.advance_poses or ()),
                           ("curriculum.stage1_poses", cfg.curriculum.stage1_poses),
                           ("pose_weights", cfg.pose_weights),
                           ("assist.poses", cfg.assist.poses or ())):
            unknown = set(named) - set(POSES)
            if unknown:
                raise ValueError(f"{key} has unknown poses {sorted(unknown)}; "
                                 f"known: {list(POSES)}")
        self.episode_sums: dict[str, np.ndarray] = {}
        self.nan_resets = 0
        self._state: dict[str, Any] = {}
        """The step's quantities (:func:`read_step_state`), in :attr:`_sim`'s kind of array."""
        self._host: dict[str, np.ndarray] = {}
        """Those of :data:`HOST_STATE` as numpy arrays, for the host's bookkeeping."""
        groups = self.layout.group_slots
        self._at = StepIndices(
            self.layout, (groups["left_foot"], groups["right_foot"]),
            np.concatenate([groups["hands"], groups["elbows"]]), groups["torso"],
            self.feet, self.knees, self.qadr, self.dadr)
        self._reset(np.arange(n))
        self._read_state()
        self._read_state(np.arange(n))
        self._obs = self._observations()

    # ------------------------------------------------------------------ public API
    def get_observations(self) -> TensorDict:
        return self._obs

    def applied_push(self, index: int) -> np.ndarray:
        """The world force on env ``index``'s torso this step (push and assistance), (3,)
        [N]."""
        return self._to_host(self._sim["xfrc_applied"][index, self.torso, :3]).copy()

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """One control step of every env; finished envs are reset inside it.

        An env whose action a_t (N, 27) holds NaN or inf is a fault of that env alone: it
        is stepped with a_t = 0, then reset, counted in :attr:`nan_resets` and logged as
        ``termination/nan``; no NaN reaches an observation or a reward.
        """
        xp, sim = self._xp, self._sim
        raw = self._from_torch(actions)
        bad = ~xp.all(xp.isfinite(raw), axis=1)  # read with the physics' flags, once
        raw = xp.where(bad[:, None], 0.0, raw)
        self.last_action = self.action
        self.action = clip_action(raw)
        lo_hi = sim["jnt_range"][:, 1:1 + self.num_actions]
        # within this episode's (scaled) joint ranges, applied delay_steps substeps late
        sim["ctrl"][:] = joint_targets(self.action, self.cfg.action_scale,
                                       (lo_hi[..., 0], lo_hi[..., 1]))
        push = self.pushes.force(self.upright_time, self.rng, self.curriculum.difficulty)
        if self.assist.active:
            helped = self.assist.assisted(self._pose_names)[self.start_pose]  # 7 names, not N
            h = self._host
            push = push.copy()
            push[:, 2] += helped * self.assist.force_z(h["mass"], h["gravity_b"], GRAVITY,
                                                       h["height"])
        sim["xfrc_applied"][:, self.torso, :3] = self._to_sim(push)
        failed = self._physics(bad)
        self.episode_length_buf += 1
        self._read_state()
        h = self._host
        dones_by = {
            "torso_contact": h["torso_force"] > self.cfg.torso_force_limit,
            "stuck_low": self.stuck.update(h["height"], self.dt,
                                           h["height"] < self.cfg.upright_height),
            "nan": failed,
        }
        terminated = np.logical_or.reduce(list(dones_by.values()))
        time_out = (self.episode_length_buf.numpy() >= self.max_episode_length) & ~terminated
        dones_by["timeout"] = time_out
        reward, parts = compute_rewards(self._reward_state(terminated), self.cfg.rewards,
                                        self.h_star, self.dt)
        reward = xp.where(self._to_sim(failed), 0.0, reward)
        values = self._to_host(xp.stack(list(parts.values()))) if parts else ()
        for name, value in zip(parts, values, strict=True):
            self.episode_sums.setdefault(name, np.zeros(self.num_envs))
            self.episode_sums[name] += np.where(failed, 0.0, value)
        self.upright_time = success_step(self.upright_time, h, self.dt)
        self.succeeded |= self.upright_time >= 1.0
        self.up_time = success_step(self.up_time, h, self.dt, still=False)
        self.stood_up |= self.up_time >= 1.0
        self._count_starts(np.flatnonzero(self.stood_up & ~self._start_counted))
        self._count_windows(np.flatnonzero(self._window_outcome() & ~self._window_counted))
        done = terminated | time_out
        extras = {"time_outs": torch.from_numpy(time_out), "log": {}}
        ids = np.flatnonzero(done)
        if len(ids):
            extras["log"] = self._episode_log(ids, dones_by)
            self._reset(ids)
            self._read_state(ids)
        self._obs = self._observations()
        return self._obs, self._to_torch(reward), torch.from_numpy(done), extras

    # ------------------------------------------------------------------ physics
    def _physics(self, bad_action: Any) -> np.ndarray:
        """Steps ``decimation`` substeps (the actuators apply the delayed targets); resets
        and returns the failed envs (N,) bool: those with a non-finite action
        (``bad_action``, :attr:`_sim`'s kind) and those whose simulation failed or
        diverged (one read from the device for both): a non-finite state, a speed above
        :data:`~hybrid_recovery.sim.divergence.MAX_SPEED`, or, on CPU MuJoCo, a clock that
        did not advance (:func:`~hybrid_recovery.sim.divergence.clock_broken`: MuJoCo
        reset the simulation as unstable)."""
        failed = np.zeros(self.num_envs, dtype=bool)
        clock = self.sims.bind("time") if self._device is None else None
        before = None if clock is None else clock.copy()
        # the DC model's force ranges follow the speeds: one substep at a time
        # (the derived fields only after the last: qvel, all the model reads, is state)
        substeps = [self.cfg.decimation] if self.motors is None else [1] * self.cfg.decimation
        for k, nstep in enumerate(substeps):
            if self.motors is not None:
                self.motors.apply()
            last = k == len(substeps) - 1
            try:
                self.sims.step(nstep=nstep, stage=mujoco.mjtStage.mjSTAGE_VEL if last
                               else mujoco.mjtStage.mjSTAGE_NONE)
            except mjbatch.SimulationError as err:
                failed[np.asarray(err.ids)] = True
        if clock is not None and before is not None:  # CPU MuJoCo resets what it finds unstable
            dt = self.model.opt.timestep
            failed |= clock_broken(before, clock, self.cfg.decimation * dt, dt)
        xp, q, v = self._xp, self._sim["qpos"], self._sim["qvel"]
        bad = ~xp.all(xp.isfinite(q), axis=1) | ~xp.all(xp.isfinite(v), axis=1)
        failed |= self._to_host(bad_action | bad | xp.any(xp.abs(v) > MAX_SPEED, axis=1))
        if failed.any():
            self.nan_resets += int(failed.sum())
            ids = np.flatnonzero(failed)
            self._reset(ids)
        return failed

    # ------------------------------------------------------------------ state
    def _com_height(self, qpos: np.ndarray) -> float:
        data = mujoco.MjData(self.model)
        data.qpos[:] = qpos
        mujoco.mj_forward(self.model, data)
        return float(data.subtree_com[1, 2])

    def _read_state(self, ids: np.ndarray | None = None) -> None:
        """The step's quantities from the simulation, for all envs or just the reset
        ``ids``."""
        xp, sim = self._xp, self._sim
        rows = slice(None) if ids is None else self._rows(ids)
        sensordata = xp.asarray(sim["sensordata"][rows], copy=True)
        ground = None if self.terrain is None else self.terrain.ground(  # under the CoM
            sensordata[:, self.layout.com][:, None, :2], ids)[:, 0]
        new = read_step_state(
            sensordata, sim["xmat"][rows], sim["qpos"][rows],
            sim["qvel"][rows], xp.asarray(sim["actuator_force"][rows], copy=True),
            xp.sum(sim["body_mass"][rows, 1:], axis=1), self.prev_momentum[rows],
            self.prev_com_vel[rows], self._at, self.dt, ground)
        momentum = new.pop("momentum")
        self.prev_momentum[rows] = xp.astype(momentum, self.prev_momentum.dtype)
        self.prev_com_vel[rows] = xp.astype(new["com_vel"], self.prev_com_vel.dtype)
        if ids is not None:  # a new episode: no history for the finite differences
            for key in ("net_force", "net_torque", "com_acc"):
                new[key] = xp.zeros_like(new[key])
        if ids is None:
            self._state = new
        else:
            for key, value in new.items():
                self._state[key][rows] = value
        self._host = self._host_state()

    def _host_state(self) -> dict[str, np.ndarray]:
        """:data:`HOST_STATE` as numpy arrays: from a device in one transfer (as columns of
        one array, in the widest of their dtypes)."""
        values = [self._state[key] for key in HOST_STATE]
        if self._device is None:
            return dict(zip(HOST_STATE, values, strict=True))
        packed = torch.cat([value.reshape(self.num_envs, -1) for value in values],
                           dim=1).cpu().numpy()
        widths = [value[0].numel() for value in values]
        columns = np.split(packed, np.cumsum(widths)[:-1], axis=1)
        return {key: column.reshape(value.shape)
                for key, value, column in zip(HOST_STATE, values, columns, strict=True)}

    def _reward_state(self, terminated: np.ndarray) -> RewardState[Any]:
        """The reward terms' inputs; ``terminated`` (N,) bool on the host."""
        return reward_state(self._state, self._sim["jnt_range"][:, 1:1 + self.num_actions],
                            self.velocity_limit, self.action, self.last_action,
                            self._to_sim(terminated))

    def _observations(self) -> TensorDict:
        xp, s = self._xp, self._state
        clean = actor_observation(s["gyro"], s["quat"], s["q"], s["dq"], self.action)
        noise = self.rng.uniform(-1.0, 1.0, clean.shape).astype(np.float32) * self.noise
        noisy = clean + self._to_sim(noise)
        critic = clean
        if self.cfg.privileged_critic:
            privileged = privileged_observation(s, self._sim["qpos"][:, :2])
            critic = xp.concat([clean, xp.astype(privileged, xp.float32)], axis=1)
            if self.terrain is not None:  # the ground around the base: the critic's alone
                w, x, y, z = (s["quat"][:, i] for i in range(4))
                yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
                ground = self.terrain.heights_around(self._sim["qpos"][:, :3], yaw)
                critic = xp.concat([critic, xp.astype(ground, xp.float32)], axis=1)
        return TensorDict({"policy": self._to_torch(noisy), "critic": self._to_torch(critic)},
                          batch_size=[self.num_envs])

    # ---------------------------------------------------------- the step's arrays
    def _step_arrays(self) -> dict[str, Any]:
        """The arrays each control step reads and writes: CPU MuJoCo's numpy arrays, or
        torch views of MuJoCo Warp's (on its device, which holds the state)."""
        names = ("qpos", "qvel", "ctrl", "xfrc_applied", "sensordata", "xmat", "actuator_force")
        arrays: dict[str, Any]
        if self._device is None:
            arrays = {name: self.sims.bind(name) for name in names}
            return arrays | {"jnt_range": self.randomizer.jnt_range,
                             "body_mass": self.randomizer.mass}
        warp = cast("WarpBatch", self.sims)
        arrays = {name: warp.tensor(name) for name in names}
        return arrays | {name: warp.model_tensor(name) for name in ("jnt_range", "body_mass")}

    def _to_sim(self, value: np.ndarray) -> Any:
        """A host array as one of :attr:`_sim`'s kind (on its device)."""
        return value if self._device is None else torch.as_tensor(value, device=self._device)

    def _to_host(self, value: Any) -> np.ndarray:
        return value if isinstance(value, np.ndarray) else value.cpu().numpy()

    def _from_torch(self, value: torch.Tensor) -> Any:
        """The learner's actions (N, 27) as :attr:`_sim`'s kind of array (on a device in
        float64; :func:`~hybrid_recovery.robot.action.clip_action` makes numpy's float64)."""
        value = value.detach()
        return value.cpu().numpy() if self._device is None else \
            value.to(self._device, torch.float64)

    def _to_torch(self, value: Any) -> torch.Tensor:
        """A returned tensor (rewards, observations): float32, where it was computed."""
        if isinstance(value, np.ndarray):
            return torch.from_numpy(value.astype(np.float32))
        return value.to(torch.float32)

    def _rows(self, ids: np.ndarray) -> Any:
        """Row indices ``ids`` for :attr:`_sim`'s arrays."""
        return ids if self._device is None else torch.from_numpy(np.asarray(ids)).to(self._device)

    # ------------------------------------------------------------------ resets
    def _sample_poses(self, count: int) -> np.ndarray:
        weights = np.array([self.cfg.pose_weights.get(p, 0.0) for p in POSES])
        if self.curriculum.stage == 1:
            weights = weights * np.isin(POSES, self.cfg.curriculum.stage1_poses)
        elif self.curriculum.stage == 2:
            hard = np.isin(POSES, _HARD_POSES)
            weights = np.where(hard, weights * self.curriculum.level, weights)
        if weights.sum() <= 0:
            raise ValueError(f"pose_weights give no pose to start from: {self.cfg.pose_weights}")
        return self.rng.choice(len(POSES), size=count, p=weights / weights.sum())

    def _reset(self, ids: np.ndarray) -> None:
        n, dr, rng = len(ids), self.cfg.domain_rand, self.rng
        poses = self._sample_poses(n)
        qpos = np.empty((n, self.model.nq))
        qvel = np.zeros((n, self.model.nv))
        levels = np.full(n, -1)
        recorded = np.zeros(n, dtype=bool)
        for k, name in enumerate(POSES):
            rows = np.flatnonzero(poses == k)
            if not len(rows):
                continue
            if self.rises.active(name):
                levels[rows], recorded[rows] = self.rises.level[name], True
                qpos[rows], qvel[rows] = self.rises.draw(name, len(rows), rng)
                continue
            if not self.bridge.active(name):
                pool = self.pool[name][0]
                qpos[rows] = pool[rng.integers(len(pool), size=len(rows))]
                continue
            levels[rows] = self.bridge.level[name]
            pool = self.bridge_pool[self.bridge.pool_name(name)][0]
            qpos[rows] = pool[rng.integers(len(pool), size=len(rows))]
        settled = ~recorded
        qpos[settled] = perturb_start(qpos[settled], rng, dr.init_base_pos, dr.init_base_rot,
                                      dr.init_joint_pos, self.qadr,
                                      self.model.jnt_range[1:1 + self.num_actions])
        # a recorded state is physically valid as it is: only turned to a random heading
        qpos[recorded], qvel[recorded] = turned(qpos[recorded], qvel[recorded],
                                                rng.uniform(-np.pi, np.pi, recorded.sum()))
        self.start_pose[ids], self.start_level[ids] = poses, levels
        self.randomizer.set_limits(ids, self.curriculum.torque_scale,
                                   self.curriculum.position_limit_factor)
        if self.motors is not None:
            self.motors.reset(ids)
        # start inside this episode's (scaled) joint ranges: the limit constraint would
        # kick a start beyond them (squatting: 14 rad/s within 60 ms at factor 0.9)
        lo, hi = self.randomizer.jnt_range[ids, 1:1 + self.num_actions].transpose(2, 0, 1)
        qpos[:, self.qadr] = np.clip(qpos[:, self.qadr], lo, hi)
        self.sims.reset(ids, stage=mujoco.mjtStage.mjSTAGE_NONE)
        self.qpos[ids] = qpos
        self.qvel[ids] = qvel
        if settled.any():
            seat_on_ground(self.model, self.sims, ids[settled])
        if self.terrain is not None:  # recorded rises start on flat ground
            self.terrain.draw(ids, rng, flat=recorded)
            seated = self.qpos[ids]
            self.terrain.seat(ids, seated, rng)
            self.qpos[ids] = seated
        self.randomizer.randomize(ids, rng, self.curriculum.difficulty)
        delay = rng.integers(self._delay_steps[0], self._delay_steps[1] + 1, n)
        self.delay_steps[ids] = delay
        # the control recorded d substeps earlier, held (half a substep keeps it exact)
        self.actuator_delay[ids] = (np.maximum(delay - 0.5, 0.0) * self.cfg.physics_dt)[:, None]
        start = self.qpos[ids][:, self.qadr]
        self.ctrl[ids] = start
        history = self.history[ids]
        history[:, self._history_values] = start[:, :, None]  # hold the start pose
        self.history[ids] = history
        sim_ids = self._rows(ids)
        self.action[sim_ids] = 0.0
        self.last_action[sim_ids] = 0.0
        self.xfrc[ids] = 0.0
        self.sims.forward(ids)
        self.pushes.reset(ids, rng)
        com = self.sims.bind("sensordata")[ids, self.layout.com]
        height = com[:, 2] if self.terrain is None else \
            com[:, 2] - self.terrain.ground(com[:, None, :2], ids)[:, 0]
        self.stuck.reset(ids, height)
        self.episode_length_buf[torch.from_numpy(ids)] = 0
        self.upright_time[ids] = 0.0
        self.succeeded[ids] = False
        self.up_time[ids] = 0.0
        self.stood_up[ids] = False
        self._start_counted[ids] = False
        self._window_counted[ids] = False
        for sums in self.episode_sums.values():
            sums[ids] = 0.0

    def _episode_log(self, ids: np.ndarray, dones_by: dict[str, np.ndarray]) -> dict:
        steps = np.maximum(self.episode_length_buf.numpy()[ids], 1)
        log: dict[str, torch.Tensor | float] = {}
        for name, sums in self.episode_sums.items():
            log[f"reward/{name}"] = torch.from_numpy(sums[ids] / (steps * self.dt))
        for name in TERMINATIONS:
            log[f"termination/{name}"] = torch.from_numpy(dones_by[name][ids].astype(np.float32))
        log["episode/success"] = torch.from_numpy(self.succeeded[ids].astype(np.float32))
        log["episode/stood_up"] = torch.from_numpy(self.stood_up[ids].astype(np.float32))
        for k, pose in enumerate(POSES):  # by start pose, only when such episodes ended
            mine = ids[self.start_pose[ids] == k]
            if len(mine):
                log[f"pose_success/{pose}"] = torch.from_numpy(
                    self.succeeded[mine].astype(np.float32))
                log[f"pose_stood_up/{pose}"] = torch.from_numpy(
                    self.stood_up[mine].astype(np.float32))
        self._count_starts(ids)
        self._count_windows(ids)
        for target in self.bridge.targets:
            log[f"bridge_blend/{target}"] = float(self.bridge.blend(target))
        for pose in self.rises.poses:
            log[f"rise_level/{pose}"] = float(self.rises.level[pose])
            log[f"rise_rate/{pose}"] = self.rises.rate(pose)
        log["episode/final_com_height"] = torch.from_numpy(self._host["height"][ids])
        if self.terrain is not None:
            self.terrain.record(self._window_outcome()[ids])
            log["curriculum/terrain_level"] = float(self.terrain.level)
        log["curriculum/assist_fraction"] = float(self.assist.fraction)
        log["curriculum/stage"] = float(self.curriculum.stage)
        log["curriculum/level"] = float(self.curriculum.level)
        log["curriculum/torque_scale"] = float(self.curriculum.torque_scale)
        log["episode/nan_resets_total"] = float(self.nan_resets)
        return log

    # ---------------------------------------------------------- outcome windows
    # An outcome is counted once per episode, as soon as it is known: a rise when it
    # happens, a failure when the episode ends. Counted only at the end, a window fills
    # with the failures first (stuck low after 2 s; a risen robot stays up until the
    # 20 s timeout), and after each level change, or resume, the bridges stepped back
    # on windows of failures (docs/experiments.md, §2).
    def _window_outcome(self) -> np.ndarray:
        """The curriculum's and the assistance's outcome so far (``advance_on``), (N,) bool."""
        return self.stood_up if self.cfg.curriculum.advance_on == "stood_up" else self.succeeded

    def _count_starts(self, ids: np.ndarray) -> None:
        """Adds the stood-up outcomes of the not yet counted episodes ``ids`` to their
        bridge's or rise's window, with their start levels."""
        if not (self.bridge.targets or self.rises.poses):  # nothing to count, every step
            return
        ids = ids[~self._start_counted[ids]]
        self._start_counted[ids] = True
        names = self._pose_names[self.start_pose[ids]]
        for pose in self.bridge.targets + self.rises.poses:
            mine = ids[names == pose]
            if len(mine):
                started = self.bridge if pose in self.bridge.targets else self.rises
                started.record(pose, self.stood_up[mine], self.start_level[mine])

    def _count_windows(self, ids: np.ndarray) -> None:
        """Adds the outcomes of the not yet counted episodes ``ids``:
        assisted episodes anneal the assistance, the others (of ``advance_poses``, from the
        pose's own starts) count for the curriculum, which waits while every pose is
        assisted. Episodes started along a recorded rise or a bridge are their level's
        (:meth:`_count_starts`), not the curriculum's: a rise's last stretch stands almost
        up already."""
        ids = ids[~self._window_counted[ids]]
        self._window_counted[ids] = True
        if not len(ids):
            return
        outcome = self._window_outcome()[ids]
        gated = self.cfg.curriculum.advance_poses
        scored = np.ones(len(ids), dtype=bool) if gated is None else \
            np.isin(self._pose_names[self.start_pose[ids]], gated)
        scored &= self.start_level[ids] < 0  # the pose's own starts
        if self.assist.active and self.cfg.assist.poses is None:
            self.assist.record(outcome[scored])
        else:
            helped = self.assist.assisted(self._pose_names)[self.start_pose[ids]]
            self.assist.record(outcome[helped])
            self.curriculum.record(outcome[scored & ~helped])
