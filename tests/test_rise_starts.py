"""Starts along recorded rises: stretches of the move, the reverse curriculum's advance
and retreat, its checkpoint, bad recordings refused, and env resets from recorded states."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from hybrid_recovery.envs import RecoveryEnv, default_config
from hybrid_recovery.envs.config import BridgeConfig, RiseConfig
from hybrid_recovery.envs.rise_starts import (
    RiseStarts,
    load_rises,
    move_progress,
    stretch_of,
    turned,
)
from hybrid_recovery.evaluation.getup_record import record_rises
from hybrid_recovery.observation import projected_gravity
from hybrid_recovery.policy import is_shipped
from hybrid_recovery.sim.initial_states import POSES, settle_pool
from hybrid_recovery.sim.scene import build_scene
from hybrid_recovery.training.checkpoint import atomic_save, load_checkpoint
from hybrid_recovery.training.config import TrainConfig
from hybrid_recovery.training.runner import train
from hybrid_recovery.training.stages import stage_config
from hybrid_recovery.training.variants import variant_overrides, variant_train_config

NQ, NV = 34, 33
PHASES = ["settle"] * 2 + ["tuck/knee_chest"] * 16 + ["policy"] * 3 + ["qp"]
"""One synthetic episode: a 16-sample move (samples 2–17), hand-over at sample 18."""


def write_recording(path: Path, qpos: np.ndarray, qvel: np.ndarray, pose: str = "sitting",
                    episodes: int = 2, **replace: np.ndarray) -> Path:
    """A recording as ``getup record`` writes it: ``episodes`` of :data:`PHASES` at 50 Hz."""
    arrays = dict(qpos=qpos, qvel=qvel, time=np.tile(np.arange(len(PHASES)) * 0.02, episodes),
                  episode=np.repeat(np.arange(episodes), len(PHASES)),
                  phase=np.array(PHASES * episodes), pose=np.array(pose))
    arrays.update(replace)
    np.savez_compressed(path, **arrays)
    return path


def numbered(episodes: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """States whose base x is 100 · episode + sample index (each row identifiable)."""
    count = episodes * len(PHASES)
    qpos, qvel = np.zeros((count, NQ)), np.ones((count, NV))
    qpos[:, 0] = 100 * np.repeat(np.arange(episodes), len(PHASES)) + \
        np.tile(np.arange(len(PHASES)), episodes)
    qpos[:, 3] = 1.0
    return qpos, qvel


def test_the_move_runs_from_the_settle_to_the_hand_over_in_equal_stretches():
    time = np.arange(len(PHASES)) * 0.02
    on_move, u = move_progress(time, np.zeros(len(PHASES), int), np.array(PHASES))
    assert np.flatnonzero(on_move).tolist() == list(range(2, 18))
    np.testing.assert_allclose(u[on_move], np.arange(16) / 16)
    assert np.isnan(u[~on_move]).all()
    # stretch 0 ends at the hand-over, stretch K − 1 begins at the ground pose
    assert stretch_of(u[on_move], 8).tolist() == [7, 7, 6, 6, 5, 5, 4, 4, 3, 3, 2, 2, 1, 1, 0, 0]
    assert stretch_of(u[on_move], 1).tolist() == [0] * 16
    # without a hand-over the move runs to the episode's end
    on_move, u = move_progress(time[:10], np.zeros(10, int), np.array(PHASES[:10]))
    assert np.flatnonzero(on_move).tolist() == list(range(2, 10))
    np.testing.assert_allclose(u[on_move], np.arange(8) / 8)


def test_starts_drawn_at_a_level_are_the_recorded_states_of_its_stretch(tmp_path):
    qpos, qvel = numbered()
    qvel[:, 6] = qpos[:, 0]  # the velocity travels with its own state
    rises = RiseStarts(RiseConfig(files=(str(write_recording(tmp_path / "s.npz", qpos, qvel)),)),
                       NQ, NV)
    assert rises.poses == ("sitting",) and rises.level == {"sitting": 0}
    rng = np.random.default_rng(0)
    for level in range(8):
        rises.level["sitting"] = level
        q, v = rises.draw("sitting", 200, rng)
        first = 2 + 2 * (7 - level)  # the stretch's two samples in each episode
        expected = {e * 100 + first + j for e in (0, 1) for j in (0, 1)}
        assert set(q[:, 0].tolist()) == expected
        rows = [int(np.flatnonzero(qpos[:, 0] == x)[0]) for x in q[:, 0]]
        np.testing.assert_array_equal(q, qpos[rows])  # exact recorded states
        np.testing.assert_array_equal(v[:, 6], q[:, 0])
    assert rises.active("sitting") and not rises.active("supine")
    rises.level["sitting"] = 8
    assert not rises.active("sitting")  # level K: the pose's own settled starts


def test_each_move_sample_knows_how_many_follow_it_on_its_move(tmp_path):
    """Two files of two episodes each, 16-sample moves: 15 … 0 in each."""
    qpos, qvel = numbered()
    files = tuple(str(write_recording(tmp_path / f"{name}.npz", qpos, qvel)) for name in "ab")
    moves = RiseStarts(RiseConfig(files=files), NQ, NV).moves["sitting"]
    assert moves.remaining.tolist() == list(range(15, -1, -1)) * 4
    np.testing.assert_array_equal(moves.qpos[moves.remaining == 15, 0], [2, 102, 2, 102])


def test_the_level_advances_and_retreats_on_the_stand_up_rate_of_its_own_starts(tmp_path):
    path = str(write_recording(tmp_path / "s.npz", *numbered()))
    rises = RiseStarts(RiseConfig(files=(path,), levels=4, advance=0.8, retreat=0.3, window=5),
                       NQ, NV)
    at = np.zeros
    assert rises.record("sitting", np.array([False] * 5), at(5, int)) == 0  # not below 0
    assert rises.record("sitting", np.array([True] * 3), at(3, int)) == 0
    assert rises.rate("sitting") == 0.6  # the window holds the last 5: F F T T T
    assert rises.record("sitting", np.array([True]), at(1, int)) == 1  # 4 of 5 = 0.8
    assert rises.level["sitting"] == 1 and rises.rate("sitting") == 0.0  # cleared
    # starts of the level left behind count for nothing; the window began afresh
    assert rises.record("sitting", np.array([True] * 9), at(9, int)) == 0
    assert rises.record("sitting", np.array([True, False, True, False]), np.ones(4, int)) == 0
    assert rises.record("sitting", np.array([False]), np.ones(1, int)) == 0  # 0.4: hold
    assert rises.record("sitting", np.array([False]), np.ones(1, int)) == -1  # last 5: 0.2
    assert rises.level["sitting"] == 0
    rises.level["sitting"] = 3
    assert rises.record("sitting", np.ones(5, bool), np.full(5, 3)) == 1
    assert not rises.active("sitting")
    assert rises.record("sitting", np.zeros(5, bool), np.full(5, 4)) == 0  # done: stays


def test_levels_and_windows_round_trip_and_rescale(tmp_path):
    path = str(write_recording(tmp_path / "s.npz", *numbered()))
    rises = RiseStarts(RiseConfig(files=(path,), window=4), NQ, NV)
    rises.level["sitting"] = 5
    rises.record("sitting", np.array([True, False, True]), np.full(3, 5))
    again = RiseStarts(RiseConfig(files=(path,), window=4), NQ, NV)
    again.load_state_dict(rises.state_dict())
    assert again.level == {"sitting": 5}
    assert again.state_dict() == rises.state_dict() == {
        "level": {"sitting": 5}, "levels": 8, "outcomes": {"sitting": [True, False, True]}}
    four = RiseStarts(RiseConfig(files=(path,), levels=4, window=4), NQ, NV)
    four.load_state_dict({**rises.state_dict(), "level": {"sitting": 5, "supine": 2}})
    assert four.level == {"sitting": 2} and four.state_dict()["outcomes"] == {"sitting": []}


def test_bad_recordings_and_settings_are_refused_verbatim(tmp_path):
    qpos, qvel = numbered()
    good = write_recording(tmp_path / "good.npz", qpos, qvel)
    how = ("write one with `hybrid-recovery getup record --pose POSE --episodes N --policy P "
           "--out FILE`")
    short = tmp_path / "short.npz"
    cases = [
        (tmp_path / "none.npz", f"rises.files: no such file: {tmp_path / 'none.npz'} ({how})"),
        (write_recording(tmp_path / "q.npz", qpos[:, :30], qvel),
         f"rise recording {tmp_path / 'q.npz'}: qpos has shape (44, 30), expected (T, 34)"),
        (write_recording(tmp_path / "v.npz", qpos, qvel[:40]),
         f"rise recording {tmp_path / 'v.npz'}: qvel has shape (40, 33), expected (44, 33)"),
        (write_recording(tmp_path / "t.npz", qpos, qvel, time=np.zeros(3)),
         f"rise recording {tmp_path / 't.npz'}: time has shape (3,), expected (44,)"),
        (write_recording(tmp_path / "p.npz", qpos, qvel, pose="flying"),
         f"rise recording {tmp_path / 'p.npz'}: unknown pose 'flying'; known: {list(POSES)}"),
        (write_recording(tmp_path / "n.npz", np.where(qpos == 5, np.nan, qpos), qvel),
         f"rise recording {tmp_path / 'n.npz'}: qpos, qvel or time holds NaN or inf"),
        (write_recording(tmp_path / "m.npz", qpos, qvel, phase=np.array(["policy"] * 44)),
         f"rise recording {tmp_path / 'm.npz'}: no move (no sample after the settle and "
         f"before the hand-over to the policy)"),
    ]
    np.savez(short, qpos=qpos, qvel=qvel)
    cases.append((short, f"rise recording {short} has no ['time', 'episode', 'phase', "
                         f"'pose'] ({how})"))
    for path, message in cases:
        with pytest.raises(ValueError) as err:
            RiseStarts(RiseConfig(files=(str(path),)), NQ, NV)
        assert str(err.value) == message
    with pytest.raises(ValueError) as err:  # 16 samples cannot fill 32 stretches
        RiseStarts(RiseConfig(files=(str(good),), levels=32), NQ, NV)
    assert str(err.value) == (f"rise recording {good}: rises.levels = 32 leaves stretches "
                              f"{list(range(0, 32, 2))} without a sample; use fewer levels")
    for bad, message in (
            ({"levels": 0}, "RiseConfig.levels must be >= 1, got 0"),
            ({"window": 0}, "RiseConfig.window must be >= 1, got 0"),
            ({"advance": 0.1}, "RiseConfig.retreat must be < advance, got retreat 0.15 and "
                               "advance 0.1"),
            ({"retreat": -0.1}, "RiseConfig.retreat must be >= 0 and <= 1, got -0.1")):
        with pytest.raises(ValueError) as err:  # refused where the config is made
            RiseConfig(**{"files": (str(good),), **bad})
        assert str(err.value) == message
    cfg = RiseConfig(files=(str(good),))
    cfg.advance = 0.1  # set after construction, as --set does
    with pytest.raises(ValueError) as err:
        RiseStarts(cfg, NQ, NV)
    assert str(err.value) == ("rises needs levels >= 1, window >= 1 and 0 <= retreat < "
                              "advance <= 1; got 8, 128, 0.15, 0.1")


def test_turning_a_state_about_the_vertical_keeps_what_the_floor_cannot_tell_apart():
    rng = np.random.default_rng(1)
    qpos, qvel = rng.normal(size=(5, NQ)), rng.normal(size=(5, NV))
    qpos[:, 3:7] /= np.linalg.norm(qpos[:, 3:7], axis=1, keepdims=True)
    yaw = rng.uniform(-np.pi, np.pi, 5)
    q, v = turned(qpos, qvel, yaw)
    np.testing.assert_array_equal(q[:, 2], qpos[:, 2])          # height
    np.testing.assert_array_equal(q[:, 7:], qpos[:, 7:])        # joints
    np.testing.assert_array_equal(v[:, 2:], qvel[:, 2:])        # ż, body rates, joint rates
    np.testing.assert_allclose(projected_gravity(q[:, 3:7]), projected_gravity(qpos[:, 3:7]),
                               atol=1e-12)                      # tilt
    np.testing.assert_allclose(np.linalg.norm(v[:, :2], axis=1),
                               np.linalg.norm(qvel[:, :2], axis=1))
    def moment(p: np.ndarray, u: np.ndarray) -> np.ndarray:  # (p × u)_z about the axis
        return p[:, 0] * u[:, 1] - p[:, 1] * u[:, 0]

    np.testing.assert_allclose(moment(q, v), moment(qpos, qvel))
    np.testing.assert_allclose(turned(q, v, -yaw)[0], qpos, atol=1e-12)


@pytest.fixture(scope="module")
def sitting_file(tmp_path_factory) -> Path:
    """A recording of settled sitting states (physically valid) with a small motion."""
    model, _ = build_scene(None, 0.005)
    qpos, _ = settle_pool(model, per_pose=len(PHASES), rng=np.random.default_rng(2),
                          nthread=1)["sitting"]
    qpos = np.concatenate([qpos, qpos])
    qvel = np.zeros((len(qpos), NV))
    qvel[:, 0], qvel[:, 5] = 0.2, 0.5  # forward 0.2 m/s, turning 0.5 rad/s
    return write_recording(tmp_path_factory.mktemp("rises") / "sitting.npz", qpos, qvel)


def test_an_env_resets_from_recorded_states_and_steps_without_nan(sitting_file):
    cfg = default_config()
    cfg.num_envs, cfg.num_threads, cfg.seed = 12, 1, 5
    cfg.curriculum.enabled = False
    cfg.pose_weights = {"sitting": 1.0, "kneeling": 1.0}
    cfg.bridge = BridgeConfig(levels=4, pairs=(("squatting", "sitting"),
                                               ("half_kneeling", "kneeling")))
    cfg.rises = RiseConfig(files=(str(sitting_file),), levels=4, window=10_000)
    env = RecoveryEnv(cfg)
    assert env.bridge.targets == ("kneeling",)  # sitting's bridge gives way to its rises
    env.rises.level["sitting"] = 2
    ids = np.arange(env.num_envs)
    env._reset(ids)
    sit = env.start_pose == POSES.index("sitting")
    assert sit.any() and (~sit).any()
    assert (env.start_level[sit] == 2).all() and (env.start_level[~sit] == 0).all()
    moves = env.rises.moves["sitting"]
    stretch = moves.qpos[moves.stretch == 2]
    for i in np.flatnonzero(sit):  # a recorded state, turned to some heading: exact
        match = np.flatnonzero((stretch[:, 7:] == env.qpos[i, 7:]).all(1))
        assert len(match) and env.qpos[i, 2] == stretch[match[0], 2]
        np.testing.assert_allclose(projected_gravity(env.qpos[i:i + 1, 3:7]),
                                   projected_gravity(stretch[match[0]][None, 3:7]), atol=1e-12)
        assert np.hypot(*env.qvel[i, :2]) == pytest.approx(0.2)
        assert env.qvel[i, 5] == 0.5
    assert (env.qvel[~sit] == 0).all()
    for _ in range(25):
        obs, reward, done, extras = env.step(torch.zeros(env.num_envs, env.num_actions))
        assert torch.isfinite(obs["policy"]).all() and torch.isfinite(obs["critic"]).all()
        assert torch.isfinite(reward).all()
    assert obs["policy"].shape == (12, 87) and obs["critic"].shape == (12, 104)
    assert reward.shape == done.shape == (12,) and env.nan_resets == 0
    # the sitting robots are still on the ground after 0.5 s of zero action
    assert (env._state["height"][sit] < 0.7).all()
    env._reset(ids)
    sit = env.start_pose == POSES.index("sitting")
    env.stood_up[:] = sit  # every sitting start rose: counted at its start level
    log = env._episode_log(ids, {n: np.zeros(env.num_envs, bool) for n in
                                 ("torso_contact", "stuck_low", "nan", "timeout")})
    assert env.rises.state_dict()["outcomes"]["sitting"] == [True] * int(sit.sum())
    assert log["rise_level/sitting"] == 2.0 and "bridge_blend/sitting" not in log
    assert log["rise_rate/sitting"] == 1.0


def test_the_rise_levels_are_checkpointed_and_resumed(tmp_path, sitting_file):
    run = tmp_path / "run"
    overrides = {"curriculum.enabled": False, "pose_weights": {"sitting": 1.0},
                 "rises.files": [str(sitting_file)], "rises.levels": 4,
                 "rises.advance": 1.0, "rises.window": 100_000}
    cfg = TrainConfig(num_envs=8, iterations=2, save_interval=1, num_threads=1,
                      env_overrides=overrides)
    train(run, cfg)
    data = load_checkpoint(run / "latest.pt")
    assert data["infos"]["rises"]["level"] == {"sitting": 0}
    data["infos"]["rises"] = {"level": {"sitting": 3}, "levels": 4,
                              "outcomes": {"sitting": [True, False]}}
    atomic_save(data, run / "latest.pt")
    cfg.iterations = 3
    resumed = train(run, cfg, resume=True)
    assert resumed.env.rises.level == {"sitting": 3}  # none can be earned: the saved one
    saved = load_checkpoint(run / "latest.pt")["infos"]["rises"]
    assert saved["level"] == {"sitting": 3} and saved["outcomes"]["sitting"][:2] == [True, False]


def test_a_run_with_rises_names_the_recordings_it_needs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    cfg = variant_train_config("recovery", num_envs=4, iterations=1, num_threads=1,
                               env_overrides={"rises.files": ["rises/sitting.npz"]})
    with pytest.raises(ValueError) as err:
        train(tmp_path / "run", cfg)
    assert str(err.value) == (
        "rises.files: no such file: rises/sitting.npz (write one with `hybrid-recovery getup "
        "record --pose POSE --episodes N --policy P --out FILE`)")
    assert not (tmp_path / "run").exists()  # refused before a file is written


def test_the_recipe_is_the_lineages_first_part_then_its_own_rises_and_the_teacher(tmp_path):
    cfg = variant_train_config("recovery_rises", num_envs=4, iterations=1, num_threads=1)
    assert cfg.env_overrides == {} and cfg.init_std == 0.5 and cfg.stages is not None
    assert variant_overrides("recovery_rises") == variant_overrides("recovery")
    rises = stage_config(cfg, "rises", tmp_path, cfg.stages)
    assert rises.env_overrides == {"rises.files": [str(tmp_path / "rises" / "sitting.npz"),
                                                   str(tmp_path / "rises" / "supine.npz")],
                                   "rises.levels": 16}
    assert (rises.teacher.learning_rate, rises.teacher.anneal_iterations) == (1e-4, 300)


@pytest.mark.skipif(not is_shipped(), reason="no shipped policy")
def test_a_real_recording_splits_into_equal_stretches_of_its_move(tmp_path):
    out = record_rises("supine", 1, tmp_path / "supine.npz", duration=20.0, seed=3,
                       policy="shipped")
    assert out["kept"] == 1
    rec = np.load(tmp_path / "supine.npz")
    pose, moves = load_rises(tmp_path / "supine.npz", 8, NQ, NV)
    phase = rec["phase"].tolist()
    first = next(i for i, p in enumerate(phase) if p != "settle")
    # the move: every sample from the end of the settle to the hand-over, in order
    np.testing.assert_array_equal(moves.qpos, rec["qpos"][first:phase.index("policy")])
    counts = np.bincount(moves.stretch, minlength=8)
    assert pose == "supine" and counts.max() - counts.min() <= 1
    assert (np.diff(moves.stretch) <= 0).all()  # from the ground pose (7) to the hand-over (0)
