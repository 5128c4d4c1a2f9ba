"""The bridge probes of ``research/`` on a one-iteration run, its actor replaced by one that
holds the joints where they are: no rise, every episode stuck low after ``stuck_time``, and
the motion figures equal to those computed from what that actor saw."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import mujoco
import numpy as np
import pytest
import torch

from hybrid_recovery.dynamics import GRAVITY
from hybrid_recovery.envs import default_config
from hybrid_recovery.evaluation.trial import eval_model
from hybrid_recovery.getup.to_squat import plan_keyframes
from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS
from hybrid_recovery.training import TrainConfig, train

SCRIPTS = Path(__file__).resolve().parents[1] / "research"
EPISODES = 4


def _script(name: str) -> ModuleType:
    if str(SCRIPTS) not in sys.path:  # as when run: the scripts import their neighbours
        sys.path.insert(0, str(SCRIPTS))
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    run = tmp_path_factory.mktemp("run")
    train(run, TrainConfig(num_envs=8, iterations=1, save_interval=1, num_threads=1))
    return run


class Holder:
    """An actor whose targets are the current joint angles (the robot cannot rise), which
    records what it sees before each step: the CoM (N, 3) and the shins' s_z (N, 2); and
    the start heading, from the pelvis's yaw (N, 2)."""

    def __init__(self, env) -> None:
        self.env, self.com, self.shin_up = env, [], []
        w, x, y, z = env.qpos[:, 3:7].T
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        self.heading = np.stack([np.cos(yaw), np.sin(yaw)], 1)

    def __call__(self, obs) -> torch.Tensor:
        s = self.env._state
        self.com.append(s["com"].copy())
        self.shin_up.append(s["shin_up"].copy())
        action = (s["q"] - DEFAULT_JOINT_POS) / self.env.cfg.action_scale
        return torch.from_numpy(action.astype(np.float32))


def _holding(module: ModuleType, monkeypatch) -> list[Holder]:
    """Replaces the actor of ``module``'s ``bridge_env`` by a :class:`Holder` made at the
    first start; returns the list that will hold it."""
    bridge_env, holders = module.bridge_env, []

    def holding_env(*args):
        env, _, data = bridge_env(*args)
        start = module.start_episodes

        def start_and_hold(env):
            obs = start(env)
            holders.append(Holder(env))
            return obs

        monkeypatch.setattr(module, "start_episodes", start_and_hold, raising=False)
        return env, lambda obs: holders[-1](obs), data

    monkeypatch.setattr(module, "bridge_env", holding_env)
    return holders


def test_rise_motion_of_a_kneeling_robot_holding_its_joints(run, monkeypatch):
    module = _script("probe_rise_motion")
    holders = _holding(module, monkeypatch)
    out = module.motion(run, 2, [2], EPISODES, 3, "half_kneeling", "kneeling")
    assert out["iteration"] == 0 and list(out["levels"]) == ["2/2"]
    level = out["levels"]["2/2"]
    assert level["stood_up"] == 0.0 and level["stood_up_medians"] is None
    assert level["ended_by"] == {"stuck_low": EPISODES}
    failed = level["failed_medians"]
    assert failed["length_s"] == pytest.approx(2.0)  # the env's stuck_time
    # the same figures from what the actor saw: the start and the states after every step
    # but the last, which ended the episodes and reset them
    (holder,) = holders
    steps = int(round(2.0 / 0.02))
    com = np.stack(holder.com)
    assert len(com) == steps
    travel = np.einsum("tnk,nk->tn", com[1:, :, :2] - com[0, :, :2], holder.heading)
    want = {"com_ahead_m": np.maximum(travel.max(0), 0.0),
            "com_behind_m": np.maximum(-travel.min(0), 0.0),
            "peak_height_m": com[1:, :, 2].max(0),
            "shin_up": np.stack(holder.shin_up).max(2).max(0)}
    for name, value in want.items():
        assert failed[name] == pytest.approx(np.median(value), abs=1e-3), name
    assert failed["shin_up"] < 0.5  # both shins still down


def test_no_bridge_level_rises_holding_its_joints(run, monkeypatch):
    module = _script("probe_bridge_levels")
    monkeypatch.setattr(module, "first_episodes",
                        lambda env, actor, first=module.first_episodes: first(env, Holder(env)))
    out = module.probe(run, 2, EPISODES, 3, "squatting", "sitting", torque_scale=2.0)
    assert out["stood_up_by_level"] == {"0/2": 0.0, "1/2": 0.0, "2/2": 0.0}
    assert out["torque_scale"] == pytest.approx(2.0) and out["episodes"] == EPISODES
    with pytest.raises(ValueError, match="torque-scale"):
        module.probe(run, 2, EPISODES, 3, "squatting", "sitting", torque_scale=0.5)


def test_no_rise_level_rises_holding_its_joints(run, monkeypatch, tmp_path):
    from hybrid_recovery.sim.initial_states import settle_pool
    from hybrid_recovery.sim.scene import build_scene

    model, _ = build_scene(None, 0.005)
    qpos, _ = settle_pool(model, per_pose=6, rng=np.random.default_rng(0), nthread=1)["supine"]
    phase = ["settle"] + ["roll/tuck"] * 4 + ["policy"]  # a 4-sample move in one episode
    np.savez(tmp_path / "supine.npz", qpos=qpos, qvel=np.zeros((6, model.nv)),
             time=np.arange(6) * 0.02, episode=np.zeros(6, int), phase=np.array(phase),
             pose=np.array("supine"))
    module = _script("probe_rise_levels")
    monkeypatch.setattr(module, "first_episodes",
                        lambda env, actor, watch=None, first=module.first_episodes:
                        first(env, Holder(env), watch))
    out = module.probe(run, tmp_path / "supine.npz", 2, EPISODES, 3, seconds=3.0)
    assert out["pose"] == "supine" and out["episodes"] == EPISODES
    assert out["stood_up_by_level"] == {"0/2": 0.0, "1/2": 0.0, "2/2": 0.0}
    # lying on its back holding its joints: chest up from the start, never turned over
    assert out["chest_up_at_start_by_level"] == {"0/2": 1.0, "1/2": 1.0, "2/2": 1.0}
    assert out["turned_chest_down_by_level"] == {"0/2": 0.0, "1/2": 0.0, "2/2": 0.0}


def test_assisted_pose_probe_pulls_at_each_fraction_and_never_anneals(run, monkeypatch):
    module = _script("probe_assisted_poses")
    pulls: dict[float, list[np.ndarray]] = {}

    def holding_first(env, actor, first=module.first_episodes):
        holder, seen = Holder(env), pulls.setdefault(env.assist.fraction, [])

        def act(obs):
            # the torso's vertical force of the step before, over the robot's weight m g
            seen.append(env.xfrc[:, env.torso, 2] / (env._state["mass"] * GRAVITY))
            return holder(obs)

        return first(env, act)

    monkeypatch.setattr(module, "first_episodes", holding_first)
    out = module.probe(run, "kneeling", [0.0, 0.6], EPISODES, 3)
    assert out["stood_up_by_fraction"] == {"0": 0.0, "0.6": 0.0}
    assert out["pose"] == "kneeling" and out["episodes"] == EPISODES
    unassisted, pulled = np.stack(pulls[0.0][1:]), np.stack(pulls[0.6][1:])
    assert np.all(unassisted == 0.0)
    # a kneeling torso is upright: the pull acts (0.6 m g) whenever no push does
    assert np.median(pulled) == pytest.approx(0.6, abs=1e-3)
    with pytest.raises(ValueError, match="unknown pose"):
        module.probe(run, "lotus", [0.0], EPISODES, 3)
    with pytest.raises(ValueError, match="fractions"):
        module.probe(run, "kneeling", [1.0], EPISODES, 3)


def test_the_side_sit_probe_chain_holds_every_keyframe_statically():
    from hybrid_recovery.control.torque_model import load_torque_model
    from hybrid_recovery.dynamics import RobotModel
    from hybrid_recovery.getup.feasibility import static_feasibility

    probe = _script("probe_side_sit")
    model = load_torque_model()
    robot = RobotModel(model)
    chain = probe.side_sit_chain(model)
    assert [name for name, _, _ in chain][::5] == ["a0.1", "a0.6", "b0.25"]
    lo, hi = model.jnt_range[1:, 0], model.jnt_range[1:, 1]
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    for name, qpos, contacts in chain:
        check = static_feasibility(robot, qpos, contacts)  # refuses a contact 3 cm up
        assert check.feasible and check.worst_ratio < 0.5, (name, check.reason)
        assert np.all(np.abs(qpos[7:] - mid) <= 0.9 * half + 1e-9), name


def test_ab_update_trains_each_setting_once_and_draws(tmp_path, monkeypatch, capsys):
    """Each (setting, seed) is a run with that setting's PPO update; a finished run is
    kept, not trained again; the table has one row per setting."""
    module = _script("ab_update")
    argv = ["ab_update.py", "--root", str(tmp_path / "ab"), "--seeds", "3", "--iterations",
            "1", "--num-envs", "8", "--threads", "1", "--variant", "full",
            "--settings", "5 epochs, fp32", "2 epochs, fp32", "--out", str(tmp_path / "ab.png")]
    monkeypatch.setattr(sys, "argv", argv)
    module.main()
    runs = {label: module.run_dir(tmp_path / "ab", label, 3)
            for label in ("5 epochs, fp32", "2 epochs, fp32")}
    for label, run_dir in runs.items():
        saved = json.loads((run_dir / "config.json").read_text())["train_config"]
        assert saved["ppo"]["num_learning_epochs"] == module.SETTINGS[label]["num_learning_epochs"]
        assert saved["seed"] == 3
    stamps = {label: (d / "latest.pt").stat().st_mtime_ns for label, d in runs.items()}
    module.main()
    assert {label: (d / "latest.pt").stat().st_mtime_ns for label, d in runs.items()} == stamps
    table = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ")]
    assert [row.split(" | ")[0] for row in table[-2:]] == ["| 5 epochs, fp32", "| 2 epochs, fp32"]
    assert (tmp_path / "ab.png").stat().st_size > 0


def test_rise_pace_fits_each_pose_and_draws(tmp_path, monkeypatch, capsys):
    """A level rising 4 per 1000 iterations from 100 on reaches K = 8 at iteration 2100;
    one that stays at 0 never does."""
    from torch.utils.tensorboard import SummaryWriter

    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({
        "env_config": {"rises": {"levels": 8}},
        "train_config": {"num_envs": 4, "num_steps_per_env": 2}}))
    writer = SummaryWriter(str(run))
    for it in range(100, 200):
        writer.add_scalar("rise_level/sitting", 0.004 * (it - 100), it)
        writer.add_scalar("rise_level/supine", 0.0, it)
        writer.add_scalar("pose_stood_up/sitting", 0.5, it)
        writer.add_scalar("Perf/collection_time", 1.0, it)
        writer.add_scalar("Perf/learning_time", 0.5, it)
    writer.close()
    module = _script("plot_rise_pace")
    from hybrid_recovery.training.record import load_lineage

    pace = module.rise_pace(load_lineage([run])[0], 8, since=0)
    assert pace["sitting"]["slope"] == pytest.approx(0.004)
    assert pace["sitting"]["left"] == pytest.approx(2100 - 199)
    assert pace["supine"]["left"] == float("inf")
    assert pace["sitting"]["top"] == pytest.approx(0.396) and pace["sitting"]["top_since"] == 199
    assert pace["supine"]["top"] == 0.0 and pace["supine"]["top_since"] == 100
    with pytest.raises(ValueError, match="fewer than two"):
        module.rise_pace(load_lineage([run])[0], 8, since=199)
    monkeypatch.setattr(sys, "argv", ["plot_rise_pace.py", str(run), "--since", "100",
                                      "--old-pace", "0.0625", "--out", str(tmp_path / "p.png")])
    module.main()
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| s")]
    assert rows[0].startswith("| sitting | ") and "| 0.40 at 199 | " in rows[0]
    assert "| 1,901 | 0 M | 0.8 |" in rows[0]
    assert rows[1].startswith("| supine | ") and "never" in rows[1]
    assert (tmp_path / "p.png").stat().st_size > 0


def test_fork_ab_compares_the_levels_up_to_the_iteration_both_runs_reached(tmp_path, monkeypatch,
                                                                          capsys):
    """Two forks from iteration 100: one's level climbs one per 10 iterations to 60
    logged, the other's stays at 2 for 30; the common end is 129."""
    from torch.utils.tensorboard import SummaryWriter

    module = _script("plot_fork_ab")
    dirs = {}
    for label, (count, level) in {"a": (60, lambda i: i // 10), "b": (30, lambda i: 2)}.items():
        run = dirs[label] = tmp_path / label
        run.mkdir()
        (run / "config.json").write_text(json.dumps({
            "env_config": {"rises": {"levels": 16}},
            "train_config": {"num_envs": 4, "num_steps_per_env": 2}}))
        writer = SummaryWriter(str(run))
        for i in range(count):
            writer.add_scalar("rise_level/sitting", level(i), 100 + i)
            writer.add_scalar("pose_stood_up/sitting", 0.5, 100 + i)
        writer.add_scalar("rise_level/sitting", 9.0, 50)  # before the fork: not counted
        writer.close()
    monkeypatch.setattr(sys, "argv", ["plot_fork_ab.py", f"a={dirs['a']}", f"b={dirs['b']}",
                                      "--since", "100", "--block", "10",
                                      "--out", str(tmp_path / "ab.png")])
    module.main()
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| a")
            or line.startswith("| b")]
    assert rows == ["| a | sitting | 60 | 5 | 2.0 at 129 |",
                    "| b | sitting | 30 | 2 | 2.0 at 129 |"]
    assert (tmp_path / "ab.png").stat().st_size > 0
    with pytest.raises(ValueError, match="b: no rise_level/<pose> logged from iteration 200"):
        module.fork_table({"b": module.read_scalars(dirs["b"])}, 200, 10)


def test_plot_deployment_pace_reads_each_checkpoints_rates_and_env_steps(tmp_path, monkeypatch,
                                                                         capsys):
    """Three evaluated checkpoints (one before the rises came in): per pose the successes of
    each results file, x the env steps since the origin's."""
    module = _script("plot_deployment_pace")

    def results(name: str, iteration: int, env_steps: int, wins: dict[str, tuple[int, int]]
                ) -> Path:
        out = tmp_path / name
        out.mkdir()
        lines = [{"key": "__header__", "controller": "onnx:x", "protocol": "poses",
                  "policy": {"iteration": iteration, "env_steps": env_steps}}]
        for pose, (k, n) in wins.items():
            lines += [{"key": f"{pose}{i}", "pose": pose, "success": i < k} for i in range(n)]
        (out / "results.jsonl").write_text("\n".join(json.dumps(x) for x in lines) + "\n")
        return out

    old = results("old", 10, 90_000_000, {"sitting": (0, 10), "supine": (1, 10)})
    origin = results("origin", 12, 100_000_000, {"sitting": (0, 10), "supine": (0, 10)})
    new = results("new", 15, 125_500_000, {"sitting": (7, 10), "supine": (3, 4)})
    monkeypatch.setattr(sys, "argv", ["plot_deployment_pace.py", f"old={old},{origin}",
                                      f"new={new}", "--origin", str(origin),
                                      "--out", str(tmp_path / "pace.png")])
    module.main()
    rows = [line for line in capsys.readouterr().out.splitlines()
            if line.startswith(("| old", "| new"))]
    assert rows == ["| old | 10 | -10.0 | 0/10 (0.0 %) | 1/10 (10.0 %) |",
                    "| old | 12 | +0.0 | 0/10 (0.0 %) | 0/10 (0.0 %) |",
                    "| new | 15 | +25.5 | 7/10 (70.0 %) | 3/4 (75.0 %) |"]
    assert (tmp_path / "pace.png").stat().st_size > 0
    (tmp_path / "qp").mkdir()
    (tmp_path / "qp" / "results.jsonl").write_text(
        json.dumps({"key": "__header__", "controller": "qp"}) + "\n")
    with pytest.raises(ValueError, match="names no checkpoint with env steps"):
        module.checkpoint_rates(tmp_path / "qp")


def test_plot_recipe_pace_finds_each_milestone_and_rejects_a_bad_rate(tmp_path, monkeypatch,
                                                                      capsys):
    """Milestone 1 needs sitting and supine at 50 %, 2 and 3 all five at 80 / 93.4 %;
    a checkpoint that misses one pose does not count; a rate above 1 is an error naming
    its line."""
    module = _script("plot_recipe_pace")
    poses = ("kneeling", "sitting", "squatting", "standing", "supine")
    lines = ["arm,iteration,m_env_steps,pose,rate,trials"]
    for it, m, rates in [(1, 10.0, (0.0, 0.6, 1.0, 1.0, 0.4)),  # supine short of 1
                         (2, 20.0, (0.7, 0.5, 1.0, 1.0, 0.5)),  # milestone 1
                         (3, 30.0, (0.9, 0.8, 0.95, 0.95, 0.8)),  # 2
                         (4, 40.0, (1.0, 0.94, 0.94, 1.0, 0.934))]:  # 3
        lines += [f"a,{it},{m},{p},{r},20" for p, r in zip(poses, rates, strict=True)]
    lines += ["b,5,1.5,sitting,0.9,", "b,5,1.5,supine,0.9,"]  # no intervals: blank trials
    table = tmp_path / "pace.csv"
    table.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(sys, "argv", ["plot_recipe_pace.py", str(table),
                                      "--out", str(tmp_path / "pace.png")])
    module.main()
    out = capsys.readouterr().out.splitlines()
    assert out == ["a (evaluated to 40.0 M): milestone 1: 20.0 M, milestone 2: 30.0 M, "
                   "milestone 3: 40.0 M",
                   "b (evaluated to 1.5 M): milestone 1: 1.5 M, milestone 2: not reached, "
                   "milestone 3: not reached"]
    assert (tmp_path / "pace.png").stat().st_size > 0
    table.write_text("arm,iteration,m_env_steps,pose,rate,trials\na,1,1.0,sitting,1.5,10\n")
    with pytest.raises(ValueError, match=r"pace.csv:2: rate 1.5 outside \[0, 1\]"):
        module.read_table(table)


@pytest.mark.warp
def test_backend_parity_probe_reports_each_pose_within_the_parity_tolerances(monkeypatch,
                                                                             capsys):
    """On the project's model over two control steps, every pose's worlds agree between
    the backends within ``test_warp_parity``'s tolerances, and the table has a row per
    pose with one cell per step."""
    pytest.importorskip("mujoco_warp", reason="MuJoCo Warp not installed (the 'warp' extra)")
    module = _script("probe_backend_parity")
    worst = module.parity(None, [1], steps=2, num_envs=8, physics_dt=0.005)
    assert len(worst) >= 4
    for pose, table in worst.items():
        assert table.shape == (2, 3)
        assert table[:, 0].max() < 1e-4 and table[:, 1].max() < 3e-3, pose
        assert table[:, 2].max() < 1e-5, pose
    monkeypatch.setattr(sys, "argv", ["probe_backend_parity.py", "--seeds", "1",
                                      "--steps", "1", "--num-envs", "8"])
    module.main()
    rows = [line for line in capsys.readouterr().out.splitlines()
            if line.startswith("| ") and not line.startswith("| pose")]
    assert {row.split(" | ")[0][2:] for row in rows} == set(worst)
    assert all(row.count(" / ") == 2 for row in rows)


def test_to_squat_probe_keeps_the_hand_over_states_and_counts_per_pose(tmp_path, monkeypatch):
    """Hand-over states are computed once and reused from the .npz (a start that never
    reaches the to-squat is remembered as missing); squats and stands are counted per pose
    with their intervals."""
    module = _script("probe_to_squat")
    asked: list[tuple[str, int]] = []

    def state(pose, seed):
        asked.append((pose, seed))
        if seed == 2:
            return None
        return {"qpos": np.full(3, seed), "qvel": np.zeros(2), "time": 6.0, "time_scale": 0.85}

    outcome = {0: "stood", 1: "fell", 3: "no_squat", 4: "stood"}
    servos: set[tuple[str, int, float]] = set()

    def replay(s, rise, time_scale=None, servo="qp", servo_every=10, range_factor=1.0):
        servos.add((servo, servo_every, range_factor))
        return outcome[int(s["qpos"][0])]

    monkeypatch.setattr(module, "hand_over_state", state)
    monkeypatch.setattr(module, "replay", replay)
    path = tmp_path / "states.npz"
    out = module.probe(["kneeling"], range(4), path, workers=1)
    assert asked == [("kneeling", s) for s in range(4)]
    row = out["kneeling"]
    assert (row["starts"], row["squats"], row["stood"]) == (3, 2, 1)
    assert row["stood_interval"][0] < 1 / 3 < row["stood_interval"][1]
    asked.clear()
    again = module.probe(["kneeling"], range(5), path, workers=1)
    assert asked == [("kneeling", 4)] and again["kneeling"]["starts"] == 4
    assert servos == {("qp", 10, 1.0)}
    module.probe(["kneeling"], range(5), path, workers=1, servo="inverse", servo_every=1)
    module.probe(["kneeling"], range(5), path, workers=1, range_factor=0.9)
    assert servos == {("qp", 10, 1.0), ("inverse", 1, 1.0), ("qp", 10, 0.9)}
    with pytest.raises(ValueError, match="unknown servo 'torque': one of"):
        module.probe(["kneeling"], range(5), path, workers=1, servo="torque")


def test_to_squat_probe_servos_drive_the_same_move():
    """From hands and knees the move's three servos run to an outcome; the keyframe servo
    (PD to q_g) does not bring the robot to a squat the rise accepts from this start, the
    QP's torques do (the figures of docs/experiments.md §12)."""
    module = _script("probe_to_squat")
    model = eval_model(None, 0.002, True, "default")
    qpos = plan_keyframes(model)["hands_knees"]
    state = {"qpos": qpos, "qvel": np.zeros(model.nv), "time": 0.0, "time_scale": 0.85}
    outcomes = {servo: module.replay(state, 1.0, servo=servo) for servo in module.SERVOS}
    assert set(outcomes.values()) <= {"stood", "fell", "no_squat"}
    assert outcomes["qp"] != "no_squat" and outcomes["keyframe"] == "no_squat", outcomes


def test_stuck_probe_ends_a_still_continuation_after_stuck_time_and_never_a_rising_one():
    """The env's own stuck-low over recorded continuations: a 4 s move lying still is
    ended 2 s after each start that has 2 s of move left; one rising 4 cm/s never."""
    module = _script("probe_recorded_rises")
    cfg = default_config()
    rows = np.arange(200)
    last = np.full(200, 199)
    still = module.stuck_on_continuations(np.full(200, 0.3), last, cfg, 0.02)
    np.testing.assert_allclose(still[:100], 2.0)
    assert np.isnan(still[100:]).all()
    rising = module.stuck_on_continuations(0.3 + 0.04 * rows * 0.02, last, cfg, 0.02)
    assert np.isnan(rising).all()
    # two moves: a continuation ends at its own move's end
    two = module.stuck_on_continuations(np.full(200, 0.3), np.repeat([99, 199], 100), cfg, 0.02)
    assert np.isnan(two).all()


def test_recorded_rise_probe_measures_joints_beyond_the_scaled_ranges():
    module = _script("probe_recorded_rises")
    model = eval_model(None, 0.002, True, "default")
    qpos = np.tile(model.qpos0, (3, 1))
    knee = model.joint("left_knee_joint")
    lo, hi = model.jnt_range[knee.id]
    qpos[1, knee.qposadr[0]] = hi  # at the hardware limit: beyond 0.9 by (hi − lo) · 0.05
    qpos[2, knee.qposadr[0]] = (lo + hi) / 2
    excess = module.beyond_ranges(model, qpos, 0.9)
    column = knee.id - 1
    assert excess[1, column] == pytest.approx((hi - lo) * 0.05)
    assert excess[2, column] == pytest.approx(-(hi - lo) * 0.45)
    assert (module.beyond_ranges(model, qpos, 1.0)[1:, column] <= 1e-12).all()


def test_to_squat_probe_scales_the_joint_ranges_and_clips_the_state_into_them():
    module = _script("probe_to_squat")
    model = eval_model(None, 0.002, True, "default")
    data = mujoco.MjData(model)
    knee = model.joint("left_knee_joint")
    lo, hi = model.jnt_range[knee.id].copy()
    data.qpos[knee.qposadr[0]] = hi
    base = data.qpos[:7].copy()
    module.scale_ranges(model, data, 0.9)
    margin = (hi - lo) * 0.05
    np.testing.assert_allclose(model.jnt_range[knee.id], [lo + margin, hi - margin])
    assert data.qpos[knee.qposadr[0]] == pytest.approx(hi - margin)
    np.testing.assert_array_equal(data.qpos[:7], base)  # the free joint is not a hinge


def test_rise_path_probe_tells_hands_and_knees_from_standing():
    path = _script("probe_rise_path")
    model = eval_model(None, 0.002, True, "default")
    data = mujoco.MjData(model)
    data.qpos[:] = plan_keyframes(model)["hands_knees"]
    for _ in range(10):  # the keyframe's knees hover a few mm: lowered until they touch
        mujoco.mj_forward(model, data)
        if path.sample_of(model, data)[2]:
            break
        data.qpos[2] -= 0.002
    z, up, hands_knees, soles_off, grounded, flight = path.sample_of(model, data)
    assert hands_knees and grounded and not soles_off and not flight  # toes down, no sole flat
    assert 0.3 < z < 0.7 and -0.9 < up < 0.9  # pelvis pitched forward
    data.qpos[:] = 0.0
    data.qpos[2], data.qpos[3] = 1.03, 1.0
    data.qpos[7:] = DEFAULT_JOINT_POS
    mujoco.mj_forward(model, data)
    z, up, hands_knees, soles_off, grounded, flight = path.sample_of(model, data)
    assert not hands_knees and not grounded and up == pytest.approx(1.0)
    data.qpos[2] += 0.5  # lifted off the floor: in flight
    mujoco.mj_forward(model, data)
    assert path.sample_of(model, data)[3:] == (True, False, True)
