"""The imitation teacher: recorded move states and actions, the annealed Adam steps, its
checkpoint, and the settings that switch it on."""

from __future__ import annotations

from dataclasses import astuple
from pathlib import Path

import numpy as np
import pytest
import torch
from tensordict import TensorDict
from test_rise_starts import NV, PHASES, write_recording

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import NoiseConfig, RiseConfig
from hybrid_recovery.observation.actor import noise_halfwidths
from hybrid_recovery.robot.action import joint_targets
from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS
from hybrid_recovery.sim.initial_states import POSES, settle_pool
from hybrid_recovery.sim.scene import build_scene
from hybrid_recovery.training.checkpoint import load_checkpoint
from hybrid_recovery.training.config import (
    TeacherConfig,
    TrainConfig,
    amend_train_config,
    train_config_from_dict,
)
from hybrid_recovery.training.minibatches import GatheredOnceStorage
from hybrid_recovery.training.runner import train
from hybrid_recovery.training.split_update import SplitUpdatePPO
from hybrid_recovery.training.teacher import Teacher, TeacherPPO, teacher_samples

TRAINING_NOISE = noise_halfwidths(*astuple(NoiseConfig()))
"""(87,) the training's actor observation noise half-widths."""
MOVE = slice(2, 18)
"""The move's samples in each synthetic episode (:data:`tests.test_rise_starts.PHASES`)."""
HELD = [6, 7]
"""Samples whose targets hold their keyframe (the first episode's 5th and 6th move
samples): not the teacher's."""


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> tuple[Path, np.ndarray]:
    """Two episodes of settled sitting states whose move samples carry keyframes (a
    different, identifiable one per sample) and targets short of them except at
    :data:`HELD`; NaN off the move, as ``getup record``. Returns the path and the
    keyframes."""
    model, _ = build_scene(None, 0.005)
    qpos, _ = settle_pool(model, per_pose=len(PHASES), rng=np.random.default_rng(4),
                          nthread=1)["sitting"]
    qpos = np.concatenate([qpos, qpos])
    qvel = np.zeros((len(qpos), NV))
    qvel[:, 3:6] = [0.3, -0.2, 0.5]  # body-frame angular velocity of the base
    qvel[:, 6:] = np.linspace(-1.0, 1.0, NV - 6)
    goal = np.full((len(qpos), 27), np.nan)
    for ep in range(2):
        rows = np.arange(len(PHASES))[MOVE] + ep * len(PHASES)
        goal[rows] = DEFAULT_JOINT_POS + 0.01 * np.arange(len(rows))[:, None] + 0.1 * ep
    target = goal - 0.05
    target[HELD] = goal[HELD]  # two samples of the first episode's move hold their keyframe
    path = write_recording(tmp_path_factory.mktemp("teach") / "sitting.npz", qpos, qvel,
                           target=target, goal=goal)
    return path, goal


def test_the_move_states_give_the_actions_that_command_their_targets(recording):
    path, goal = recording
    model, _ = build_scene(None, 0.005)
    obs, actions = teacher_samples([path], model, 0.3)
    taught = np.isfinite(goal).all(1)
    taught[HELD] = False
    assert obs.shape == (30, 87) and actions.shape == (30, 27) and obs.dtype == np.float32
    # a* commands exactly the recorded keyframes through the policy's action → target map
    np.testing.assert_allclose(joint_targets(actions, 0.3), goal[taught], atol=1e-6)
    # a_{t−1}: the previous move sample's action, a held one included; a move's first
    # sample has its own
    last = joint_targets(obs[:, 60:], 0.3)
    previous = np.flatnonzero(taught) - 1
    previous[[0, 14]] += 1  # the moves' first samples (rows 2 and 24)
    np.testing.assert_allclose(last, goal[previous], atol=1e-6)
    assert previous[4] == 7  # after the hold: the held keyframe


def test_the_move_observations_are_the_envs_observations_of_those_states(recording):
    """The same recorded states seated in the training env (its own batched sensors, at a
    random heading): gyro, gravity, joints and joint speeds agree."""
    path, _ = recording
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 8, 1, 3
    cfg.curriculum.enabled = False
    cfg.pose_weights = {"sitting": 1.0}
    cfg.rises = RiseConfig(files=(str(path),), levels=1, window=10_000)
    env = RecoveryEnv(cfg)
    obs, _ = teacher_samples([path], env.model, cfg.action_scale)
    ids = np.arange(env.num_envs)
    env._reset(ids)
    env._read_state(ids)
    seen = env._observations()["critic"].numpy()[:, :60]  # the clean actor observation
    assert (env.start_pose == POSES.index("sitting")).all()
    for i in ids:  # each start's observation is one of the teacher's (held ones aside)
        gap = np.abs(obs[:, :60] - seen[i]).max(1).min()
        assert gap < 2e-5 or (env.qpos[i, 7:] == recorded_held(path)[:, 7:]).all(1).any()
    assert sum(np.abs(obs[:, :60] - seen[i]).max(1).min() < 2e-5 for i in ids) >= 6


def recorded_held(path: Path) -> np.ndarray:
    """qpos (2, nq) of the :data:`HELD` samples of the recording."""
    with np.load(path) as rec:
        return rec["qpos"][HELD]


def test_a_recording_without_keyframes_is_refused_with_the_way_to_write_one(tmp_path, recording):
    path, _ = recording
    model, _ = build_scene(None, 0.005)
    with np.load(path) as rec:
        arrays = {k: rec[k] for k in rec.files if k != "goal"}
    np.savez(tmp_path / "old.npz", **arrays)
    with pytest.raises(ValueError) as err:
        teacher_samples([tmp_path / "old.npz"], model, 0.3)
    assert str(err.value) == (
        f"rise recording {tmp_path / 'old.npz'} has no ['goal'] (the moves' targets and "
        "keyframes); re-record it with `hybrid-recovery getup record --pose POSE --episodes "
        "N --policy P --out FILE`, which writes them")
    with pytest.raises(ValueError, match="the teacher needs recorded rises: set rises.files"):
        teacher_samples([], model, 0.3)


def test_a_recording_without_joint_pd_moves_gives_no_samples(tmp_path, recording):
    path, goal = recording
    model, _ = build_scene(None, 0.005)
    with np.load(path) as rec:
        arrays = {k: rec[k] for k in rec.files}
    # the model controller's rise from the kneel: its own modes, torques throughout
    arrays["phase"] = np.where(np.char.find(arrays["phase"].astype(str), "/") >= 0, "kneel",
                               arrays["phase"])
    arrays["target"] = arrays["goal"] = np.full_like(goal, np.nan)
    np.savez(tmp_path / "kneeling.npz", **arrays)
    obs, actions = teacher_samples([path], model, 0.3)
    both = teacher_samples([tmp_path / "kneeling.npz", path], model, 0.3)
    np.testing.assert_array_equal(both[0], obs)
    np.testing.assert_array_equal(both[1], actions)
    with pytest.raises(ValueError) as err:
        teacher_samples([tmp_path / "kneeling.npz"], model, 0.3)
    assert str(err.value) == (f"no rise recording of {[str(tmp_path / 'kneeling.npz')]} holds "
                              "a joint-PD ground move for the teacher")


class LinearActor(torch.nn.Module):
    """μ = W o, read from the ``policy`` group as rsl-rl's actor does."""

    def __init__(self) -> None:
        super().__init__()
        self.linear = torch.nn.Linear(87, 27, bias=False)

    def forward(self, obs: TensorDict) -> torch.Tensor:
        return self.linear(obs["policy"])


def test_the_steps_fit_the_teacher_and_stop_once_annealed():
    rng = np.random.default_rng(0)
    obs = rng.normal(size=(512, 87)).astype(np.float32)
    actions = (obs @ rng.normal(size=(87, 27)) * 0.1).astype(np.float32)
    cfg = TeacherConfig(learning_rate=0.01, anneal_iterations=60, steps=4, batch_size=256)
    teacher = Teacher(obs, actions, np.zeros(87, np.float32), cfg, seed=1)
    torch.manual_seed(0)
    actor = LinearActor()
    first = teacher.step(actor)
    assert first["teacher_lr"] == 0.01 and teacher.updates == 1
    for _ in range(58):
        last = teacher.step(actor)
    assert last["teacher_lr"] == pytest.approx(0.01 * (1 - 58 / 60))
    assert last["teacher"] < 0.05 * first["teacher"]
    teacher.step(actor)  # the 60th: lr 0.01 / 60
    weights = actor.linear.weight.detach().clone()
    assert teacher.step(actor) == {"teacher_lr": 0.0}  # annealed: nothing moves
    assert torch.equal(actor.linear.weight, weights)
    # the clock and the Adam state come back from a checkpoint
    resumed = Teacher(obs, actions, np.zeros(87, np.float32), cfg)
    resumed.load_state_dict(teacher.state_dict())
    assert resumed.updates == 61 and resumed.learning_rate() == 0.0


def test_the_anchor_keeps_the_actor_on_its_own_states():
    """Teacher states and rollout states apart: with the anchor the actor learns the
    teacher's actions and keeps its outputs on the rollout's states; without it they
    drift with the teacher."""
    rng = np.random.default_rng(1)
    taught = 0.1 * rng.normal(size=(256, 87)).astype(np.float32)
    taught[:, 0] += 3.0
    own = 0.1 * rng.normal(size=(256, 87)).astype(np.float32)
    own[:, 0] -= 3.0
    own[:, 1] += 1.0
    target = np.ones((256, 27), np.float32)
    drift = {}
    for weight in (0.0, 1.0):
        torch.manual_seed(0)
        actor = LinearActor()
        with torch.no_grad():
            before = actor(TensorDict({"policy": torch.as_tensor(own)}, batch_size=[256]))
        cfg = TeacherConfig(learning_rate=0.01, anneal_iterations=1000, steps=4,
                            batch_size=128, anchor=weight)
        teacher = Teacher(taught, target, np.zeros(87, np.float32), cfg, seed=2)
        first = teacher.step(actor, torch.as_tensor(own))
        for _ in range(100):
            out = teacher.step(actor, torch.as_tensor(own))
        with torch.no_grad():
            after = actor(TensorDict({"policy": torch.as_tensor(own)}, batch_size=[256]))
        drift[weight] = float((after - before).pow(2).sum(-1).mean())
        assert out["teacher"] < 0.2 * first["teacher"] and ("anchor" in out) == (weight > 0)
        # the frozen start is checkpointed with the teacher
        assert (teacher.state_dict()["reference"] is not None) == (weight > 0)
    assert drift[1.0] < 0.1 * drift[0.0]


def test_the_observation_noise_is_the_trainings():
    noisy = Teacher(np.zeros((4, 87), np.float32), np.zeros((4, 27), np.float32),
                    TRAINING_NOISE, TeacherConfig(learning_rate=1.0, batch_size=4096))
    actor = LinearActor()
    seen = []
    actor.register_forward_hook(lambda m, args, out: seen.append(args[0]["policy"]))
    noisy.step(actor)
    half = torch.as_tensor(TRAINING_NOISE)
    drawn = torch.cat(seen)
    assert (drawn.abs() <= half).all()
    assert (drawn[:, :60].abs().amax(0) > 0.9 * half[:60]).all()  # the full width is used
    assert (drawn[:, 60:] == 0).all() and drawn[:, :60].std(0).min() > 0.05


def test_bad_teacher_settings_are_refused():
    data = np.zeros((4, 87), np.float32), np.zeros((4, 27), np.float32)
    for cfg in (TeacherConfig(), TeacherConfig(learning_rate=1e-3, steps=0),
                TeacherConfig(learning_rate=1e-3, anneal_iterations=0)):
        with pytest.raises(ValueError, match="the teacher needs learning_rate > 0"):
            Teacher(*data, np.zeros(87, np.float32), cfg)
    with pytest.raises(KeyError, match="unknown teacher setting 'rate'"):
        amend_train_config(TrainConfig(), {"teacher.rate": 1e-4})
    with pytest.raises(ValueError, match="teacher.steps"):
        amend_train_config(TrainConfig(), {"teacher.steps": "many"})


def test_a_run_with_a_teacher_saves_and_resumes_its_clock(tmp_path, recording):
    path, _ = recording
    overrides = {"curriculum.enabled": False, "pose_weights": {"sitting": 1.0},
                 "rises.files": [str(path)], "rises.levels": 1, "rises.window": 100_000}
    cfg = TrainConfig(num_envs=8, num_steps_per_env=4, iterations=2, save_interval=1,
                      num_threads=1, env_overrides=overrides,
                      teacher=TeacherConfig(learning_rate=1e-3, anneal_iterations=10,
                                            steps=1, batch_size=16))
    runner = train(tmp_path / "run", cfg)
    assert isinstance(runner.alg, TeacherPPO) and runner.teacher is not None
    saved = load_checkpoint(tmp_path / "run" / "latest.pt")["infos"]
    assert saved["teacher"]["updates"] == 2 and saved["teacher"]["optimizer"] is not None
    start = saved["teacher"]["reference"]
    assert start is not None and not torch.equal(  # frozen while the actor moved on
        start["mlp.0.weight"], load_checkpoint(tmp_path / "run" / "latest.pt")[
            "actor_state_dict"]["mlp.0.weight"])
    assert train_config_from_dict(saved["meta"]["train_config"]).teacher == cfg.teacher
    cfg.iterations = 3
    resumed = train(tmp_path / "run", cfg, resume=True)
    assert resumed.teacher is not None and resumed.teacher.updates == 3
    again = load_checkpoint(tmp_path / "run" / "latest.pt")["infos"]["teacher"]["reference"]
    assert all(torch.equal(again[k], start[k]) for k in start)


def test_without_a_teacher_the_algorithm_is_the_split_update_gathered_once(tmp_path, recording):
    path, _ = recording
    cfg = TrainConfig(num_envs=8, num_steps_per_env=4, iterations=1, save_interval=1,
                      num_threads=1, env_overrides={"curriculum.enabled": False})
    runner = train(tmp_path / "plain", cfg)
    assert type(runner.alg) is SplitUpdatePPO and runner.teacher is None
    assert type(runner.alg.storage) is GatheredOnceStorage
    assert load_checkpoint(tmp_path / "plain" / "latest.pt")["infos"]["teacher"] is None
    # switched on in a resumed run, it starts its clock at the amendment
    amended = train(tmp_path / "plain", TrainConfig(iterations=2, num_threads=1), resume=True,
                    amend={"teacher.learning_rate": 1e-3, "rises.files": [str(path)],
                           "pose_weights": {"sitting": 1.0}})
    assert isinstance(amended.alg, TeacherPPO)
    assert amended.teacher is not None and amended.teacher.updates == 1
    # on without recordings: refused before anything is written
    with pytest.raises(ValueError, match="the teacher needs recorded rises: set rises.files"):
        train(tmp_path / "none", TrainConfig(num_envs=4, iterations=1, num_threads=1,
                                             teacher=TeacherConfig(learning_rate=1e-3)))
    assert not (tmp_path / "none").exists()


def test_a_run_saved_with_the_anchor_switch_resumes_with_the_frozen_anchor():
    cfg = train_config_from_dict({"teacher": {"learning_rate": 1e-4, "anchor_to_start": True}})
    assert cfg.teacher == TeacherConfig(learning_rate=1e-4)
    # its recorded amendment replays to the same settings (the training record's check)
    assert amend_train_config(cfg, {"teacher.anchor_to_start": True,
                                    "teacher.anneal_iterations": 300}).teacher == \
        TeacherConfig(learning_rate=1e-4, anneal_iterations=300)
