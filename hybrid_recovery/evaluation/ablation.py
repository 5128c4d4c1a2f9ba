"""The ablation table (paper §IV-B) from training runs' TensorBoard logs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

ABLATION_METRICS = (
    ("Train/mean_reward", "mean reward"),
    ("Train/mean_episode_length", "episode length [steps]"),
    ("episode/final_com_height", "CoM height at episode end [m]"),
    ("episode/success", "stand-up success"),
    ("termination/timeout", "timeout rate"),
    ("termination/stuck_low", "stuck-low rate"),
    ("termination/torso_contact", "torso-contact rate"),
    ("curriculum/stage", "curriculum stage"),
)
"""(TensorBoard tag, row label) of the table; the paper's metrics where they exist here."""


def run_metrics(run_dir: str | Path, tail: float = 0.1,
                upto: int | None = None) -> dict[str, float]:
    """Mean of each metric over the last ``tail`` fraction of a run's logged iterations
    (each iteration once, also across resumes), of iterations ≤ ``upto`` if given."""
    from hybrid_recovery.training.record import read_scalars

    scalars = read_scalars(run_dir)
    if upto is not None:
        scalars = {tag: (steps[steps <= upto], values[steps <= upto])
                   for tag, (steps, values) in scalars.items()}
    out = {}
    for tag, _ in ABLATION_METRICS:
        if tag in scalars and len(scalars[tag][1]):
            values = scalars[tag][1]
            k = max(1, int(len(values) * tail))
            out[tag] = float(values[-k:].mean())
    out["iterations"] = float(len(scalars["Train/mean_reward"][0])) \
        if "Train/mean_reward" in scalars else 0.0
    return out


def _steps_per_iteration(run_dir: str | Path) -> int:
    config = json.loads((Path(run_dir) / "config.json").read_text())["train_config"]
    return int(config["num_envs"]) * int(config["num_steps_per_env"])


def _last_iteration(run_dir: str | Path) -> int:
    from hybrid_recovery.training.record import read_scalars

    steps = read_scalars(run_dir).get("Train/mean_reward", (np.zeros(1), None))[0]
    return int(steps.max())


def ablation_table(runs: dict[str, str | Path], same_budget: bool = True) -> str:
    """Markdown table, one column per run (label → run directory).

    With ``same_budget`` every run is cut at the env steps of the shortest one, so that
    the runs are compared after the same amount of experience (the paper's "same
    budget"); otherwise each run's whole log is used.
    """
    per_iteration = {label: _steps_per_iteration(path) for label, path in runs.items()}
    last = {label: _last_iteration(path) for label, path in runs.items()}
    upto: dict[str, int | None] = {label: None for label in runs}
    if same_budget:
        budget = min((last[label] + 1) * per_iteration[label] for label in runs)
        upto = {label: budget // per_iteration[label] - 1 for label in runs}
    metrics = {label: run_metrics(path, upto=upto[label]) for label, path in runs.items()}
    for label, m in metrics.items():
        cut = upto[label]
        end = last[label] if cut is None else cut
        m["env_steps_m"] = (end + 1) * per_iteration[label] / 1e6
    lines = ["| metric | " + " | ".join(metrics) + " |", "|---" * (len(metrics) + 1) + "|"]
    rows = ABLATION_METRICS + (("iterations", "iterations logged"),
                               ("env_steps_m", "env steps [millions]"))
    for tag, label in rows:
        cells = [f"{m[tag]:.3f}" if tag in m else "–" for m in metrics.values()]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
