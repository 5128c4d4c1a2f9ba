"""The ablation table (SPEC §7) from training runs' TensorBoard logs."""

from __future__ import annotations

from pathlib import Path

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


def run_metrics(run_dir: str | Path, tail: float = 0.1) -> dict[str, float]:
    """Mean of each metric over the last ``tail`` fraction of a run's logged iterations
    (each iteration once, also across resumes)."""
    from hybrid_recovery.training.record import read_scalars

    scalars = read_scalars(run_dir)
    out = {}
    for tag, _ in ABLATION_METRICS:
        if tag in scalars:
            values = scalars[tag][1]
            k = max(1, int(len(values) * tail))
            out[tag] = float(values[-k:].mean())
    out["iterations"] = float(len(scalars["Train/mean_reward"][0])) \
        if "Train/mean_reward" in scalars else 0.0
    return out


def ablation_table(runs: dict[str, str | Path]) -> str:
    """Markdown table, one column per run (label → run directory)."""
    metrics = {label: run_metrics(path) for label, path in runs.items()}
    lines = ["| metric | " + " | ".join(metrics) + " |", "|---" * (len(metrics) + 1) + "|"]
    for tag, label in ABLATION_METRICS + (("iterations", "iterations logged"),):
        cells = [f"{m[tag]:.3f}" if tag in m else "–" for m in metrics.values()]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)
