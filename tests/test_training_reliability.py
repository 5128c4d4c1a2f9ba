"""Training never loses or overwrites a run by accident: a new run into an existing one
is refused, a damaged checkpoint falls back to the newest intact one, a damaged
``config.json`` is named, and a resume keeps the run's own target and settings."""

from __future__ import annotations

import json

import pytest

from hybrid_recovery.cli.main import main
from hybrid_recovery.training import TrainConfig, load_checkpoint, train
from hybrid_recovery.training.checkpoint import load_latest
from hybrid_recovery.training.export import export_policy

FAST = {"curriculum.window": 8, "curriculum.advance_success": 0.0}
CLI = ["--num-envs", "8", "--save-interval", "1", "--threads", "1", "--set",
       "curriculum.window=8", "curriculum.advance_success=0.0"]


def _cfg(**kw) -> TrainConfig:
    return TrainConfig(num_envs=8, iterations=kw.pop("iterations", 2), save_interval=1,
                       num_threads=1, env_overrides=dict(FAST), **kw)


def _snapshot(run) -> dict:
    return {str(p): p.read_bytes() for p in sorted(run.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    run = tmp_path_factory.mktemp("runs") / "run"
    train(run, _cfg())
    return run


def test_a_new_run_into_an_existing_one_is_refused_and_nothing_is_touched(run_dir, capsys):
    before = _snapshot(run_dir)
    with pytest.raises(FileExistsError) as info:
        train(run_dir, _cfg())
    assert str(info.value) == (f"{run_dir} already holds a training run (config.json); continue "
                               "it with --resume or start it over with --force")
    assert main(["train", "--run-dir", str(run_dir), "--iterations", "2", *CLI]) == 2
    assert capsys.readouterr().err == f"error: {info.value}\n"
    assert _snapshot(run_dir) == before


def test_force_starts_over(tmp_path):
    run = tmp_path / "run"
    train(run, _cfg(iterations=3))
    assert load_checkpoint(run / "latest.pt")["iter"] == 2
    with pytest.raises(ValueError, match="give one"):
        train(run, _cfg(), resume=True, force=True)
    train(run, _cfg(iterations=1), force=True)
    assert load_checkpoint(run / "latest.pt")["iter"] == 0
    assert sorted(p.name for p in run.glob("model_*.pt")) == ["model_0.pt"]
    assert len(list(run.glob("events.out.tfevents*"))) == 1


def test_a_bad_setting_writes_nothing(tmp_path, capsys):
    run = tmp_path / "new"
    assert main(["train", "--run-dir", str(run), "--set", "physics_dt=0"]) == 2
    assert capsys.readouterr().err == "error: config key 'physics_dt' must be > 0, got 0\n"
    assert main(["train", "--run-dir", str(run), "--set", "curriculum.window=abc"]) == 2
    assert capsys.readouterr().err == ("error: config key 'curriculum.window' must be an "
                                       "integer, got 'abc'\n")
    with pytest.raises(SystemExit) as parse:  # argparse's own exit, in the same format
        main(["train", "--run-dir", str(run), "--num-envs", "-4"])
    assert parse.value.code == 2
    assert capsys.readouterr().err == ("error: argument --num-envs: must be an integer >= 1, "
                                       "got '-4'\n")
    assert not run.exists()


def test_a_damaged_latest_falls_back_to_the_newest_intact_checkpoint(tmp_path, capsys):
    run = tmp_path / "run"
    train(run, _cfg(iterations=3))
    latest = run / "latest.pt"
    latest.write_bytes(latest.read_bytes()[:100])  # torn by a full disk
    data, path = load_latest(run)
    assert path == run / "model_2.pt" and data["iter"] == 2
    err = capsys.readouterr().err
    assert err.startswith(f"warning: latest.pt: checkpoint {latest} is corrupt or not a torch "
                          "checkpoint: ") and err.endswith(f"; using {path} instead\n")
    exported = export_policy(run, tmp_path / "export")  # export falls back the same way
    assert json.loads((exported / "policy.json").read_text())["provenance"]["iteration"] == 2
    (run / "model_2.pt").unlink()
    latest.unlink()
    assert load_latest(run)[1] == run / "model_1.pt"
    train(run, _cfg(iterations=3), resume=True)  # continues after iteration 1
    assert load_checkpoint(latest)["iter"] == 2
    for p in run.glob("*.pt"):
        p.write_bytes(b"junk")
    with pytest.raises(ValueError) as info:
        load_latest(run)
    assert str(info.value).startswith(f"no intact checkpoint in {run}: latest.pt: checkpoint ")
    with pytest.raises(FileNotFoundError) as missing:
        train(tmp_path / "empty", _cfg(), resume=True)
    assert str(missing.value) == (f"cannot resume: no checkpoint in {tmp_path / 'empty'} "
                                  "(no latest.pt, no model_*.pt)")


def test_a_damaged_config_is_named(tmp_path, capsys):
    run = tmp_path / "run"
    train(run, _cfg())
    config = run / "config.json"
    config.write_text(config.read_text()[:200])
    with pytest.raises(ValueError) as info:
        train(run, _cfg(iterations=3), resume=True)
    assert str(info.value).startswith(f"run settings {config} are damaged (not valid JSON: ")
    assert main(["train", "--resume", "--run-dir", str(run)]) == 2
    assert capsys.readouterr().err.startswith(f"error: run settings {config} are damaged")
    with pytest.raises(ValueError) as info:
        export_policy(run, tmp_path / "export")  # the training record reads it too
    assert str(info.value).startswith(f"run settings {config} are damaged (not valid JSON: ")


def test_resume_keeps_the_runs_target_and_names_only_options_given(tmp_path, capsys):
    run = tmp_path / "run"
    train(run, _cfg(iterations=2))
    config = run / "config.json"
    meta = json.loads(config.read_text())
    meta["train_config"]["iterations"] = 3  # a run of 3 iterations stopped after 2
    config.write_text(json.dumps(meta))
    capsys.readouterr()
    assert main(["train", "--resume", "--run-dir", str(run), "--threads", "1"]) == 0
    assert load_checkpoint(run / "latest.pt")["iter"] == 2  # its own 3, not 50,000
    out = capsys.readouterr().out
    assert "ignored" not in out
    assert main(["train", "--resume", "--run-dir", str(run), "--threads", "1",
                 "--iterations", "4", "--num-envs", "16", "--init-std", "0.5"]) == 0
    assert load_checkpoint(run / "latest.pt")["iter"] == 3
    assert (f"[hybrid-recovery] resuming with the run's saved settings ({config}); these "
            "options given now are ignored: --init-std, --num-envs\n") in capsys.readouterr().out


def test_amendments_are_typed_and_ranged():
    from hybrid_recovery.training.config import amend_train_config

    amended = amend_train_config(TrainConfig(), {"ppo.entropy_coef": 0, "train.max_std": 0.3})
    assert amended.ppo.entropy_coef == 0.0 and isinstance(amended.ppo.entropy_coef, float)
    for change, message in (
            ({"ppo.entropy_coef": "abc"}, "config key 'ppo.entropy_coef' must be a number, "
                                          "got 'abc'"),
            ({"ppo.gamma": 1.5}, "config key 'ppo.gamma' must be > 0 and <= 1, got 1.5"),
            ({"train.save_interval": 0}, "config key 'train.save_interval' must be >= 1, "
                                         "got 0"),
            ({"ppo.num_mini_batches": 2.5}, "config key 'ppo.num_mini_batches' must be an "
                                            "integer, got 2.5")):
        with pytest.raises(ValueError) as info:
            amend_train_config(TrainConfig(), change)
        assert str(info.value) == message


def test_a_second_writer_of_a_run_directory_is_refused_with_the_holders_pid(run_dir, capsys):
    import subprocess
    import sys

    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time\nfrom hybrid_recovery.files import "
         "exclusive_lock\nwith exclusive_lock(sys.argv[1]):\n    print('held', flush=True)\n"
         "    time.sleep(60)\n", str(run_dir)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        before = _snapshot(run_dir)
        message = (f"{run_dir} is in use by another process (pid {holder.pid}); wait for it "
                   "to end, or stop it (kill PID: it saves and stops)")
        with pytest.raises(RuntimeError) as info:
            train(run_dir, _cfg(iterations=3), resume=True)
        assert str(info.value) == message
        assert main(["train", "--run-dir", str(run_dir), "--resume", "--iterations", "3"]) == 2
        assert capsys.readouterr().err == f"error: {message}\n"
        assert _snapshot(run_dir) == before  # nothing written beside the holder
    finally:
        holder.kill()
        holder.wait()


def test_a_checkpoint_of_other_networks_is_refused_in_one_line(tmp_path):
    run = tmp_path / "wide"
    train(run, _cfg(iterations=1, hidden_dims=(64, 32)))
    config = json.loads((run / "config.json").read_text())
    config["train_config"]["hidden_dims"] = [32, 16]  # as another variant's networks
    (run / "config.json").write_text(json.dumps(config))
    with pytest.raises(ValueError) as info:
        train(run, _cfg(iterations=2), resume=True)
    text = str(info.value)
    assert text.startswith(f"checkpoint {run / 'latest.pt'} (variant 'full') does not fit "
                           "this model's actor: ") and "\n" not in text


def test_num_envs_beyond_the_machines_memory_is_refused_before_any_allocation(tmp_path,
                                                                             capsys):
    import re

    from hybrid_recovery.sim.scene import build_scene
    from hybrid_recovery.training.memory import NotEnoughMemory, bytes_per_env, check_num_envs

    model = build_scene()[0]
    simulation, rollout = bytes_per_env(model, 24)
    # the data buffer and the touched arena; 24 transitions of ~250 float32, three copies
    assert 0.3e6 < simulation < 1e6 and 50e3 < rollout < 150e3
    check_num_envs(1024, model, 24, available=10**9)  # 0.6 GB of 1 GB: fits
    with pytest.raises(NotEnoughMemory) as err:
        check_num_envs(2048, model, 24, available=10**9)
    assert re.fullmatch(r"--num-envs 2048 needs about 1\.\d GB of memory \(\d+\.\d kB per "
                        r"environment: the simulation \d+\.\d kB, the rollout \d+\.\d kB\); "
                        r"1\.0 GB is available", str(err.value))
    run = tmp_path / "huge"
    assert main(["train", "--run-dir", str(run), "--num-envs", "50000000"]) == 2
    assert re.fullmatch(r"error: --num-envs 50000000 needs about \d+\.\d TB of memory .*\n",
                        capsys.readouterr().err)
    assert not run.exists()
