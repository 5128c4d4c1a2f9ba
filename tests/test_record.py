"""Training record: scalars de-duplicated across resumes, final figures, curves."""

from __future__ import annotations

import json

import numpy as np
import pytest
from torch.utils.tensorboard import SummaryWriter

from hybrid_recovery.evaluation.ablation import ablation_table, run_metrics
from hybrid_recovery.training import record as record_module
from hybrid_recovery.training.record import (
    FINAL_KEY,
    load_lineage,
    plot_curves,
    read_lineage,
    read_scalars,
    training_record,
)


def _fake_run(path):
    """A run logged 0..59, killed, resumed at 50 and logged 50..79 again (other values)."""
    first = SummaryWriter(str(path))
    for it in range(60):
        first.add_scalar("episode/success", 0.0, it)
        first.add_scalar("Perf/collection_time", 2.0, it)
        first.add_scalar("Perf/learning_time", 3.0, it)
    first.close()
    second = SummaryWriter(str(path))
    for it in range(50, 80):
        second.add_scalar("episode/success", it / 100.0, it)
        second.add_scalar("Perf/collection_time", 2.0, it)
        second.add_scalar("Perf/learning_time", 3.0, it)
        second.add_scalar("Train/mean_reward", float(it), it)
        if it % 2:  # logged only in iterations where such an episode ended
            second.add_scalar("pose_stood_up/supine", 1.0 if it >= 60 else 0.5, it)
    second.close()
    config = {"train_config": {"num_envs": 8, "num_steps_per_env": 24}}
    (path / "config.json").write_text(json.dumps(config))


def test_resumed_iterations_count_once_and_the_later_value_wins(tmp_path):
    _fake_run(tmp_path)
    steps, values = read_scalars(tmp_path)["episode/success"]
    np.testing.assert_array_equal(steps, np.arange(80))
    np.testing.assert_allclose(values[[49, 50, 79]], [0.0, 0.5, 0.79], rtol=1e-6)


def test_record_figures_up_to_the_checkpoint(tmp_path):
    _fake_run(tmp_path)
    checkpoint = {"iter": 69, "infos": {"env_steps": 70 * 24 * 8, "meta": {
        "variant": "full", "git_commit": "abc", "train_config": {"num_envs": 8}},
        "curriculum": {"stage": 1, "level": 0.0, "outcomes": [True] * 5}}}
    record = training_record(tmp_path, checkpoint)
    assert record["compute_time_s"] == 70 * 5.0  # iterations 0..69, each counted once
    final = record[FINAL_KEY]["episode/success"]
    assert np.isclose(final, np.mean(np.arange(50, 70) / 100.0))
    supine = record[FINAL_KEY]["pose_stood_up/supine"]
    assert np.isclose(supine, np.mean([0.5] * 5 + [1.0] * 5))  # odd iterations 51..69
    assert record["curriculum"] == {"stage": 1, "level": 0.0}
    assert plot_curves(tmp_path, tmp_path / "curves.png").stat().st_size > 10_000
    # a checkpoint that kept its own compute time (across lost logs) is believed instead
    segments = [{"iteration": 0, "hardware": {"cpu_count": 2}},
                {"iteration": 40, "hardware": {"cpu_count": 16}}]
    checkpoint["infos"].update(compute_time_s=1234.5, segments=segments)
    record = training_record(tmp_path, checkpoint)
    assert record["compute_time_s"] == 1234.5 and record["segments"] == segments
    assert record["hardware"] == {"cpu_count": 16}


def test_curves_can_stop_at_the_exported_checkpoint(tmp_path, monkeypatch):
    _fake_run(tmp_path)
    drawn = []
    real_draw = record_module._draw
    monkeypatch.setattr(record_module, "_draw",
                        lambda ax, scalar, *a, **k: (drawn.append(scalar[0].max()),
                                                     real_draw(ax, scalar, *a, **k)))
    plot_curves(tmp_path, tmp_path / "all.png")
    assert max(drawn) == 79
    drawn.clear()
    plot_curves(tmp_path, tmp_path / "upto.png", upto=69)
    assert drawn and max(drawn) == 69
    drawn.clear()  # an early checkpoint: the reward and the pose rates start at 50
    plot_curves(tmp_path, tmp_path / "early.png", upto=40)
    assert len(drawn) == 1 and max(drawn) == 40


def test_ablation_metrics_and_curves_compare_runs(tmp_path):
    full, reduced = tmp_path / "full", tmp_path / "reduced"
    for run in (full, reduced):
        run.mkdir()
        _fake_run(run)
    metrics = run_metrics(full, tail=0.1)  # last 8 of 80 iterations, each counted once
    assert metrics["iterations"] == 30.0  # mean_reward logged for 50..79 only
    assert np.isclose(metrics["episode/success"], np.mean(np.arange(72, 80) / 100.0))
    table = ablation_table({"full": full, "reduced": reduced})
    assert "| stand-up success | 0.755 | 0.755 |" in table
    out = plot_curves({"full": full, "reduced": reduced}, tmp_path / "both.png")
    assert out.stat().st_size > 10_000


def test_the_ablation_table_compares_runs_at_the_same_budget(tmp_path):
    """A run with twice the envs per iteration is cut at half the iterations; the longer
    run is cut at the shorter run's env steps."""
    long, short = tmp_path / "long", tmp_path / "short"
    long.mkdir(), short.mkdir()
    _fake_run(long)  # 80 iterations × 8 envs × 24 steps
    writer = SummaryWriter(str(short))
    for it in range(35):  # 35 iterations × 16 envs × 24 steps = 70 iterations of `long`
        writer.add_scalar("Train/mean_reward", -1.0, it)
        writer.add_scalar("termination/stuck_low", 1.0, it)
    writer.close()
    (short / "config.json").write_text(json.dumps(
        {"train_config": {"num_envs": 16, "num_steps_per_env": 24}}))
    table = ablation_table({"long": long, "short": short})
    # long: iterations 0..69, the last 10 % = 63..69
    assert f"| stand-up success | {np.mean(np.arange(63, 70) / 100.0):.3f} | – |" in table
    assert "| env steps [millions] | 0.013 | 0.013 |" in table
    assert "| stuck-low rate | – | 1.000 |" in table
    whole = ablation_table({"long": long, "short": short}, same_budget=False)
    assert f"| stand-up success | {np.mean(np.arange(72, 80) / 100.0):.3f} | – |" in whole


def test_curves_draw_the_chosen_panels(tmp_path, monkeypatch):
    _fake_run(tmp_path)
    titles = []
    real_draw = record_module._draw
    monkeypatch.setattr(record_module, "_draw",
                        lambda ax, scalar, *a, **k: (titles.append(ax.get_title()),
                                                     real_draw(ax, scalar, *a, **k)))
    chosen = (("pose_stood_up/supine", "supine"), ("Train/mean_reward", "reward"),
              ("termination/stuck_low", "not logged"), ("episode/success", "success"))
    out = plot_curves(tmp_path, tmp_path / "chosen.png", curves=chosen, by_pose=False)
    assert out.stat().st_size > 10_000
    assert titles == ["supine", "reward", "success"]  # in order; none for a missing tag
    drawn = []
    monkeypatch.setattr(record_module, "_draw",
                        lambda ax, scalar, *a, **k: drawn.append(scalar[0]))
    plot_curves(tmp_path, tmp_path / "window.png", curves=chosen, by_pose=False,
                since=55, upto=70)
    assert [(s.min(), s.max()) for s in drawn] == [(55, 69), (55, 70), (55, 70)]


def _fork(parent, path, start=60, stop=100):
    """A copy of ``parent``'s checkpoint at ``start`` resumed in ``path``: it logs from there."""
    path.mkdir()
    writer = SummaryWriter(str(path))
    for it in range(start, stop):
        writer.add_scalar("episode/success", 1.0, it)
        writer.add_scalar("Train/mean_reward", -float(it), it)
        writer.add_scalar("Train/mean_reward/time", -float(it), it - 55)  # rsl-rl: wall clock
    writer.close()
    (path / "config.json").write_text((parent / "config.json").read_text())


def test_a_fork_reads_as_one_run_from_its_lineage_root(tmp_path, monkeypatch):
    parent = tmp_path / "parent"
    parent.mkdir()
    _fake_run(parent)  # 0..79
    _fork(parent, tmp_path / "fork")  # 60..99
    merged = read_lineage([parent, tmp_path / "fork"])
    steps, values = merged["episode/success"]
    np.testing.assert_array_equal(steps, np.arange(100))  # the parent's 60..79 left out
    np.testing.assert_allclose(values[[10, 59, 60, 99]], [0.0, 0.59, 1.0, 1.0], rtol=1e-6)
    steps, values = merged["Train/mean_reward"]  # parent 50..79, fork 60..99
    np.testing.assert_array_equal(steps, np.arange(50, 100))
    assert values[9] == 59.0 and values[10] == -60.0
    assert merged["Perf/learning_time"][0].max() == 59  # the fork no longer logs it
    assert load_lineage([parent, tmp_path / "fork"])[1] == [
        {"run": "parent", "first_iteration": 0, "last_iteration": 59},
        {"run": "fork", "first_iteration": 60, "last_iteration": 99}]
    checkpoint = {"iter": 99, "infos": {"env_steps": 100 * 24 * 8, "meta": {
        "variant": "full", "git_commit": "abc", "train_config": {"num_envs": 8}}}}
    record = training_record(tmp_path / "fork", checkpoint, history=[parent])
    assert record["compute_time_s"] == 60 * 5.0  # the parent's 0..59; the fork logs none
    assert record["lineage"][0]["run"] == "parent"
    assert "lineage" not in training_record(tmp_path / "fork", checkpoint)
    checkpoint["iter"] = 90  # an earlier checkpoint of the fork, which logged on to 99
    assert training_record(tmp_path / "fork", checkpoint, history=[parent])["lineage"] == [
        {"run": "parent", "first_iteration": 0, "last_iteration": 59},
        {"run": "fork", "first_iteration": 60, "last_iteration": 90}]
    drawn = []
    monkeypatch.setattr(record_module, "_draw",
                        lambda ax, scalar, *a, **k: drawn.append(scalar[0]))
    plot_curves({"fork": [parent, tmp_path / "fork"]}, tmp_path / "lineage.png",
                curves=(("episode/success", "success"),), by_pose=False)
    assert drawn[0].min() == 0 and drawn[0].max() == 99


def test_a_lineage_without_scalars_is_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no logged scalars"):
        read_lineage([tmp_path / "empty"])
    with pytest.raises(ValueError, match="no run directories"):
        read_lineage([])


def test_the_per_pose_panel_is_a_longer_running_mean(tmp_path, monkeypatch):
    _fake_run(tmp_path)
    windows = {}
    real_draw = record_module._draw
    monkeypatch.setattr(record_module, "_draw",
                        lambda ax, scalar, *a, window=record_module.WINDOW, **k: (
                            windows.setdefault(ax.get_title().split(" (")[0], set()).add(window),
                            real_draw(ax, scalar, *a, window=window, **k)))
    plot_curves(tmp_path, tmp_path / "curves.png")
    assert windows.pop("stood up, by start pose") == {record_module.POSE_WINDOW}
    assert windows and all(w == {record_module.WINDOW} for w in windows.values())
