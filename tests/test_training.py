"""Training runs: save, resume (also after SIGKILL), export, ONNX parity, variants, bad files."""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import onnxruntime as ort
import pytest
import torch
from tensordict import TensorDict

from hybrid_recovery.envs import RecoveryEnv
from hybrid_recovery.envs.rewards import CAPTURE_POINT_TERMS
from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.sim.initial_states import POSES
from hybrid_recovery.training import TrainConfig, load_checkpoint, train
from hybrid_recovery.training.checkpoint import grow_critic_inputs
from hybrid_recovery.training.config import train_config_from_dict
from hybrid_recovery.training.export import (
    actor_from_checkpoint,
    export_policy,
    load_policy_description,
)
from hybrid_recovery.training.probe import first_episodes, training_env
from hybrid_recovery.training.runner import make_env_config
from hybrid_recovery.training.variants import VARIANTS

FAST = {"curriculum.window": 8, "curriculum.advance_success": 0.0}


def _cfg(**kw) -> TrainConfig:
    cfg = TrainConfig(num_envs=8, iterations=2, save_interval=1, num_threads=1,
                      env_overrides=dict(FAST))
    for key, value in kw.items():
        setattr(cfg, key, value)
    return cfg


@pytest.fixture(scope="module")
def trained_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    runner = train(run, _cfg())
    return run, runner


def test_run_directory_contents(trained_run):
    run, runner = trained_run
    assert (run / "latest.pt").is_file() and (run / "config.json").is_file()
    meta = json.loads((run / "config.json").read_text())
    assert meta["variant"] == "full" and meta["critic_obs_dim"] == 104
    assert len(meta["git_commit"]) in (40, 7) or meta["git_commit"] == "unknown"
    assert any(run.glob("events.out.tfevents*"))
    data = load_checkpoint(run / "latest.pt")
    assert data["iter"] == 1
    assert "stage" in data["infos"]["curriculum"]


def test_resume_continues_iteration_and_curriculum(trained_run):
    run, runner = trained_run
    saved = load_checkpoint(run / "latest.pt")
    resumed = train(run, _cfg(iterations=3), resume=True)
    assert resumed.current_learning_iteration == 2
    assert load_checkpoint(run / "latest.pt")["iter"] == 2
    # the curriculum continued from the saved state (it can only have advanced)
    before, after = saved["infos"]["curriculum"], resumed.env.curriculum.state_dict()
    assert (after["stage"], after["level"]) >= (before["stage"], before["level"])


def test_export_onnx_matches_torch(trained_run, tmp_path):
    run, _ = trained_run
    out = export_policy(run, tmp_path / "export")
    desc = load_policy_description(out / "policy.json")
    assert desc["observation"]["dim"] == ACTOR_OBS_DIM and desc["action"]["scale"] == 0.3
    assert desc["action"]["target_range_factor"] == make_env_config(
        TrainConfig()).curriculum.position_limit_final
    record = json.loads((out / "training_record.json").read_text())
    iteration = load_checkpoint(run / "latest.pt")["iter"]  # earlier tests may resume it
    assert record["iteration"] == iteration and record["env_steps"] == (iteration + 1) * 24 * 8
    assert record["compute_time_s"] > 0 and record["hardware"]["cpu_count"] >= 1
    assert (out / "curves.png").stat().st_size > 10_000
    actor = actor_from_checkpoint(load_checkpoint(run / "latest.pt"))
    session = ort.InferenceSession(str(out / "policy.onnx"))
    obs = np.random.default_rng(0).normal(size=(1, ACTOR_OBS_DIM)).astype(np.float32) * 3
    onnx_act = session.run(["actions"], {"obs": obs})[0]
    from tensordict import TensorDict

    with torch.no_grad():
        torch_act = actor(TensorDict({"policy": torch.from_numpy(obs)}, batch_size=[1]),
                          stochastic_output=False).numpy()
    np.testing.assert_allclose(onnx_act, torch_act, atol=1e-5)


def test_a_copied_checkpoint_without_logs_exports_without_curves(trained_run, tmp_path,
                                                                  capsys):
    """As `training/checkpoints/…` is: a checkpoint and its config.json, no TensorBoard logs."""
    run, _ = trained_run
    copied = tmp_path / "copied"
    copied.mkdir()
    for name in ("latest.pt", "config.json"):
        (copied / name).write_bytes((run / name).read_bytes())
    out = export_policy(copied, tmp_path / "export")
    record = json.loads((out / "training_record.json").read_text())
    assert record["iteration"] == load_checkpoint(run / "latest.pt")["iter"]
    assert record["final_mean_of_last_20_iterations"] == {}
    assert (out / "policy.onnx").is_file() and not (out / "curves.png").exists()
    assert "no training logs up to iteration" in capsys.readouterr().out


def test_corrupt_and_foreign_checkpoints_are_refused(trained_run, tmp_path):
    run, _ = trained_run
    bad = tmp_path / "bad.pt"
    bad.write_bytes((run / "latest.pt").read_bytes()[:1000])
    with pytest.raises(ValueError, match="is corrupt or not a torch checkpoint"):
        load_checkpoint(bad)
    with pytest.raises(FileNotFoundError, match="checkpoint not found"):
        load_checkpoint(tmp_path / "none.pt")
    foreign = tmp_path / "foreign.pt"
    torch.save({"actor_state_dict": {}}, foreign)
    with pytest.raises(ValueError, match="was not written by hybrid_recovery"):
        load_checkpoint(foreign)
    data = torch.load(run / "latest.pt", weights_only=False)
    data["infos"]["meta"]["joint_names"] = ["a"] * 27
    torch.save(data, tmp_path / "other_robot.pt")
    with pytest.raises(ValueError, match="was trained for joints"):
        load_checkpoint(tmp_path / "other_robot.pt")
    data["infos"]["meta"]["joint_names"] = load_checkpoint(run / "latest.pt")["infos"]["meta"][
        "joint_names"]
    data["infos"]["meta"]["actor_obs_dim"] = 90
    torch.save(data, tmp_path / "other_obs.pt")
    with pytest.raises(ValueError, match="expects an actor observation of 90 entries"):
        load_checkpoint(tmp_path / "other_obs.pt")


def test_policy_json_mismatch_is_refused(trained_run, tmp_path):
    run, _ = trained_run
    out = export_policy(run, tmp_path / "export")
    desc = json.loads((out / "policy.json").read_text())
    desc["kp"][0] += 1.0
    (out / "policy.json").write_text(json.dumps(desc))
    with pytest.raises(ValueError, match="kp differs from the robot constants"):
        load_policy_description(out / "policy.json")


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_variants_set_critic_width_and_rewards(variant):
    """(``recovery_rises`` in its first stage; its last: ``tests/test_staged_run.py``.)"""
    env_cfg = make_env_config(TrainConfig(variant=variant, num_envs=2, num_threads=1))
    env = RecoveryEnv(env_cfg)
    obs = env.get_observations()
    privileged = variant not in ("reduced", "no_privileged")
    assert obs["critic"].shape[1] == (104 if privileged else 87)
    assert obs["policy"].shape[1] == 87
    _, _, _, extras = env.step(torch.zeros(2, 27))
    for _ in range(200):
        _, _, done, extras = env.step(torch.zeros(2, 27))
        if done.any():
            break
    terms = {k.split("/", 1)[1] for k in extras["log"] if k.startswith("reward/")}
    with_cp = variant not in ("reduced", "no_capture_point")
    assert set(CAPTURE_POINT_TERMS) <= terms if with_cp else not set(CAPTURE_POINT_TERMS) & terms
    curriculum = variant not in ("reduced", "no_curriculum")
    assert env.curriculum.stage == (1 if curriculum else 3)


def test_unknown_variant_and_config_key():
    with pytest.raises(KeyError, match="unknown variant 'nope'"):
        make_env_config(TrainConfig(variant="nope"))
    with pytest.raises(KeyError, match="unknown config key 'rewards.w_nope'"):
        make_env_config(TrainConfig(env_overrides={"rewards.w_nope": 1.0}))
    saved = dataclasses.asdict(TrainConfig())
    assert train_config_from_dict(saved) == TrainConfig()
    with pytest.raises(KeyError, match=r"train_config has unknown keys \['nope'\]"):
        train_config_from_dict({**saved, "nope": True})
    with pytest.raises(KeyError, match=r"train_config.ppo has unknown keys \['lr'\]"):
        train_config_from_dict({**saved, "ppo": {**saved["ppo"], "lr": 1.0}})


def test_sigkill_then_resume_loses_at_most_one_interval(tmp_path):
    run = tmp_path / "killed"
    cmd = [sys.executable, "-m", "hybrid_recovery.cli.main", "train", "--num-envs", "8",
           "--iterations", "1000", "--save-interval", "1", "--threads", "1",
           "--run-dir", str(run), "--set"] + [f"{k}={v}" for k, v in FAST.items()]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True)
    deadline = time.time() + 120
    try:
        while time.time() < deadline:
            if (run / "latest.pt").is_file() and load_checkpoint(run / "latest.pt")["iter"] >= 2:
                break
            assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
            time.sleep(0.2)
        else:
            pytest.fail("training wrote no checkpoint at iteration 2 within 120 s")
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    saved = load_checkpoint(run / "latest.pt")  # never a partial file, even after SIGKILL
    assert not list(run.glob(".*.tmp")) or all(p.stat().st_size >= 0 for p in run.glob(".*.tmp"))
    resumed = train(run, _cfg(iterations=saved["iter"] + 2), resume=True)
    assert resumed.current_learning_iteration == saved["iter"] + 1
    state = saved["infos"]["curriculum"]
    after = resumed.env.curriculum.state_dict()
    assert (after["stage"], after["level"]) >= (state["stage"], state["level"])


def test_sigterm_stops_after_the_iteration_under_way_saved_and_resumable(tmp_path):
    run = tmp_path / "stopped"
    cmd = [sys.executable, "-m", "hybrid_recovery.cli.main", "train", "--num-envs", "8",
           "--iterations", "1000", "--save-interval", "1000", "--threads", "1",
           "--run-dir", str(run), "--set"] + [f"{k}={v}" for k, v in FAST.items()]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        assert proc.stdout is not None
        for line in proc.stdout:  # rsl-rl's report of each iteration
            if "Learning iteration 3/" in line:
                break
        else:
            pytest.fail(f"training ended early: {proc.stderr.read()[-2000:]}")
        assert load_checkpoint(run / "latest.pt")["iter"] == 0  # the only periodic save
        proc.send_signal(signal.SIGTERM)
        proc.stdout.read()
        stderr = proc.stderr.read()
        assert proc.wait(timeout=120) == 130
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    saved = load_checkpoint(run / "latest.pt")
    assert saved["iter"] >= 3  # the iteration under way when the signal came, not 0
    assert f"SIGTERM: stopped after iteration {saved['iter']}, saved; continue with --resume" \
        in stderr
    assert (run / f"model_{saved['iter']}.pt").is_file()
    resumed = train(run, _cfg(iterations=saved["iter"] + 2), resume=True)
    assert resumed.current_learning_iteration == saved["iter"] + 1


def test_a_second_signal_stops_at_once_and_handlers_are_restored():
    from hybrid_recovery.training.graceful_stop import StopRequest, stop_on_signals

    before = signal.getsignal(signal.SIGTERM)
    request = StopRequest()
    with stop_on_signals(request):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.05)  # the handler runs between bytecodes of the main thread
        assert request.signal == signal.SIGTERM
        with pytest.raises(KeyboardInterrupt, match="SIGTERM again: stopped at once"):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1.0)
    assert signal.getsignal(signal.SIGTERM) is before


def test_resume_uses_the_runs_saved_settings(tmp_path):
    run = tmp_path / "run"
    train(run, _cfg(init_std=0.5, env_overrides={**FAST, "assist.fraction": 0.3}))
    # resumed with other options: the run's own settings win, iterations come from now
    resumed = train(run, _cfg(iterations=3), resume=True)
    assert resumed.current_learning_iteration == 2
    assert resumed.env.cfg.assist.fraction == 0.3
    assert "assist" in load_checkpoint(run / "latest.pt")["infos"]
    meta = json.loads((run / "config.json").read_text())
    assert meta["train_config"]["init_std"] == 0.5 and meta["train_config"]["iterations"] == 3


def test_compute_time_and_machines_carry_across_resumes(tmp_path):
    run = tmp_path / "run"
    train(run, _cfg())
    first = load_checkpoint(run / "latest.pt")["infos"]
    train(run, _cfg(iterations=4), resume=True)
    infos = load_checkpoint(run / "latest.pt")["infos"]
    assert 0 < first["compute_time_s"] < infos["compute_time_s"]
    assert [s["iteration"] for s in infos["segments"]] == [0, 2]
    assert infos["segments"][1]["hardware"]["cpu_count"] >= 1


def test_amendments_change_a_resumed_run_and_are_recorded(tmp_path):
    run = tmp_path / "run"
    train(run, _cfg())
    with pytest.raises(ValueError, match="amendments change a resumed run"):
        train(tmp_path / "new", _cfg(), amend={"ppo.entropy_coef": 0.0})
    with pytest.raises(KeyError, match="unknown PPO setting 'entropy'"):
        train(run, _cfg(iterations=3), resume=True, amend={"ppo.entropy": 0.0})
    with pytest.raises(KeyError, match="'hidden_dims' cannot change in a resumed run"):
        train(run, _cfg(iterations=3), resume=True, amend={"train.hidden_dims": [8]})
    changes = {"ppo.entropy_coef": 0.001, "rewards.w_cp": 0.5, "train.max_std": 0.3}
    resumed = train(run, _cfg(iterations=3), resume=True, amend=changes)
    assert resumed.alg.entropy_coef == 0.001 and resumed.env.cfg.rewards.w_cp == 0.5
    # the noise std is capped in sampling (the run started at init_std 1.0)
    obs = resumed.env.get_observations()
    resumed.alg.act(obs)
    std = resumed.alg.get_policy().output_std
    assert torch.allclose(std, torch.full_like(std, 0.3))
    # a later plain resume keeps the amended settings and the history
    again = train(run, _cfg(iterations=4), resume=True)
    assert again.alg.entropy_coef == 0.001 and again.env.cfg.rewards.w_cp == 0.5
    meta = json.loads((run / "config.json").read_text())
    assert meta["train_config"]["max_std"] == 0.3
    assert meta["amendments"] == [{"iteration": 2, "git_commit": meta["git_commit"],
                                   "changes": changes}]
    assert load_checkpoint(run / "latest.pt")["infos"]["meta"]["amendments"] == \
        meta["amendments"]


def test_an_amended_assist_fraction_outranks_the_checkpoint(tmp_path):
    run = tmp_path / "run"
    train(run, _cfg(env_overrides={**FAST, "curriculum.advance_success": 1.1,
                                   "assist.fraction": 0.5}))
    assert load_checkpoint(run / "latest.pt")["infos"]["assist"]["fraction"] == 0.5
    resumed = train(run, _cfg(iterations=3), resume=True, amend={"assist.fraction": 0.0})
    assert not resumed.env.assist.active
    assert load_checkpoint(run / "latest.pt")["infos"]["assist"]["fraction"] == 0.0


def test_probe_plays_one_episode_per_env_in_the_runs_own_env(tmp_path):
    run = tmp_path / "run"
    train(run, _cfg(env_overrides={**FAST, "assist.fraction": 0.4}))
    env, data = training_env(run, 4, seed=1, overrides={"pose_weights": {"supine": 1.0}})
    assert env.assist.fraction == load_checkpoint(run / "latest.pt")["infos"]["assist"][
        "fraction"] and int(data["iter"]) == 1
    env.assist.fraction = 0.0
    steps = []

    def still(obs):  # holds the start pose: stuck low after 2 s
        steps.append(1)
        return torch.zeros(obs["policy"].shape[0], env.num_actions)

    stood, pose = first_episodes(env, still)
    assert not stood.any() and (pose == POSES.index("supine")).all()
    assert len(steps) == pytest.approx(env.cfg.stuck_time / env.dt, abs=2)


def test_override_values_are_json_and_a_broken_list_is_refused():
    from hybrid_recovery.cli.errors import UsageError
    from hybrid_recovery.cli.registry import parse_overrides

    assert parse_overrides(['bridge.pairs=[["squatting", "supine"]]', "rewards.w_cp=0",
                            "curriculum.advance_on=success", "assist.max_height=Infinity"]) == {
        "bridge.pairs": [["squatting", "supine"]], "rewards.w_cp": 0,
        "curriculum.advance_on": "success", "assist.max_height": float("inf")}
    # unquoted names: once read as the string "[prone]", i.e. the poses "[", "p", "r", ...
    for bad in ("assist.poses=[prone]", "bridge.pairs=[[squatting, supine]]", "x={a: 1}"):
        with pytest.raises(UsageError, match="not valid JSON"):
            parse_overrides([bad])
    with pytest.raises(UsageError, match="key=value"):
        parse_overrides(["rewards.w_cp"])


def test_a_run_amended_onto_terrain_keeps_its_critic_and_trains_on(tmp_path):
    """The critic gains the terrain's heights with zero weights: at the resume it values
    every observation as the saved critic did, whatever the heights, and the widened
    critic and its optimiser train on."""
    run = tmp_path / "run"
    first = train(run, _cfg())
    saved = load_checkpoint(run / "latest.pt")
    width = saved["critic_state_dict"]["mlp.0.weight"].shape[1]
    resumed = train(run, _cfg(iterations=3), resume=True,
                    amend={"terrain.enabled": True, "terrain.height_grid": 3})
    trained = load_checkpoint(run / "latest.pt")["critic_state_dict"]["mlp.0.weight"]
    assert trained.shape[1] == width + 9 and trained[:, width:].abs().sum() > 0.0
    widened = copy.deepcopy(saved)
    assert grow_critic_inputs(widened, width + 9, len(list(first.alg.actor.parameters()))) == 9
    assert grow_critic_inputs(widened, width + 9, 0) == 0
    critic = copy.deepcopy(resumed.alg.critic)
    critic.load_state_dict(widened["critic_state_dict"])
    first.alg.critic.load_state_dict(saved["critic_state_dict"])
    obs = torch.randn(5, width)
    heights = torch.rand(5, 9)
    np.testing.assert_allclose(
        critic(TensorDict({"critic": torch.cat([obs, heights], 1)}, batch_size=[5])).detach(),
        first.alg.critic(TensorDict({"critic": obs}, batch_size=[5])).detach(), rtol=1e-6)
    with pytest.raises(ValueError, match="more than"):
        grow_critic_inputs(widened, width, 0)
