"""A run's training record: provenance, hardware, compute time, final figures and curves.

Written next to an exported policy (``training_record.json``, ``curves.png``) so that a
shipped policy says how it was made. Everything is read from the run directory: the
checkpoint's metadata and the TensorBoard scalars that rsl-rl and the environment log.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from hybrid_recovery.training.stages import STAGES, StageState

CURVES: tuple[tuple[str, str], ...] = (
    ("Train/mean_reward", "mean episode reward"),
    ("episode/final_com_height", "CoM height at episode end [m]"),
    ("episode/success", "stand-up success (paper criterion)"),
    ("termination/stuck_low", "stuck-low rate"),
    ("episode/stood_up", "stood up (h_c > 0.85 m, tilt < 72° for 1 s)"),
    ("curriculum/stage", "curriculum stage"),
    ("curriculum/torque_scale", "torque limit × hardware"),
    ("Policy/mean_std", "action noise std"),
)
"""The TensorBoard tags plotted in ``curves.png`` and summarised in the record."""

FINAL_WINDOW = 20
"""Iterations averaged for the record's final figures."""
FINAL_KEY = f"final_mean_of_last_{FINAL_WINDOW}_iterations"
"""The record's key of those figures (empty where no logs reach the checkpoint)."""


def read_scalars(run_dir: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every scalar of a run as (iterations, values), one value per iteration.

    A resumed run logs the iterations after its last checkpoint twice; the later write
    wins.
    """
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(str(run_dir), size_guidance={"scalars": 0})
    acc.Reload()
    out = {}
    for tag in acc.Tags()["scalars"]:
        latest: dict[int, tuple[float, float]] = {}
        for event in acc.Scalars(tag):
            if event.step not in latest or event.wall_time >= latest[event.step][0]:
                latest[event.step] = (event.wall_time, event.value)
        steps = np.array(sorted(latest))
        out[tag] = (steps, np.array([latest[s][1] for s in steps]))
    return out


def read_lineage(run_dirs: Sequence[str | Path]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The scalars of a fork and the runs it descends from, oldest first, as one run.

    A fork (a copy of another run's checkpoint, resumed in a new directory) logs from its
    fork point only; each later directory takes over from its first logged iteration, so
    the earlier run's iterations after the fork (its own continuation) are left out, also
    of tags the fork no longer logs.
    """
    return load_lineage(run_dirs)[0]


def logged_iterations(scalars: Mapping[str, tuple[np.ndarray, np.ndarray]]) -> tuple[int, int]:
    """The first and last iteration a run logged; rsl-rl's ``…/time`` tags, logged against
    wall-clock seconds, are not iterations."""
    steps = [s for tag, (s, _) in scalars.items() if len(s) and not tag.endswith("/time")]
    return min(int(s.min()) for s in steps), max(int(s.max()) for s in steps)


class NoLoggedScalars(ValueError):
    """A run directory without TensorBoard scalars (a copied checkpoint, say)."""


def load_lineage(run_dirs: Sequence[str | Path]
                 ) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], list[dict]]:
    """:func:`read_lineage`'s scalars and, from the same read of the logs, each directory
    with the iterations it contributes (``run``, ``first_iteration``, ``last_iteration``)."""
    if not run_dirs:
        raise ValueError("read_lineage: no run directories")
    empty = (np.zeros(0, int), np.zeros(0))
    merged: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    spans = []
    for run_dir in run_dirs:
        scalars = read_scalars(run_dir)
        if not scalars:
            raise NoLoggedScalars(f"read_lineage: {run_dir} holds no logged scalars")
        start, stop = logged_iterations(scalars)
        spans.append((Path(run_dir).name, start, stop))
        for tag in merged.keys() | scalars.keys():
            old_steps, old_values = merged.get(tag, empty)
            steps, values = scalars.get(tag, empty)
            keep = old_steps < start
            merged[tag] = (np.concatenate([old_steps[keep], steps]),
                           np.concatenate([old_values[keep], values]))
    ranges = [{"run": name, "first_iteration": lo,
               "last_iteration": spans[k + 1][1] - 1 if k + 1 < len(spans) else hi}
              for k, (name, lo, hi) in enumerate(spans)]
    return merged, ranges


def hardware() -> dict:
    """The machine a run trained on, as far as Python can tell."""
    import mujoco
    import torch

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    gpu = torch.cuda.get_device_name(0) if torch.cuda.is_available() else None
    return {"cpu": cpu, "cpu_count": os.cpu_count(), "gpu": gpu,
            "python": platform.python_version(), "torch": torch.__version__,
            "mujoco": mujoco.__version__, "platform": platform.platform()}


def training_record(run_dir: str | Path, checkpoint: dict,
                    history: Sequence[str | Path] = ()) -> dict:
    """The record of the run that produced ``checkpoint`` (a loaded checkpoint dict):
    its settings, compute, curves' final values, ``origin`` (``from scratch``: no fork,
    no amendment) and, for a staged run, its stages up to the checkpoint.

    ``history``: the runs ``run_dir`` was forked from, oldest first (:func:`read_lineage`).
    """
    meta = checkpoint["infos"]["meta"]
    try:
        scalars, ranges = load_lineage([*history, run_dir])
    except NoLoggedScalars:  # a copied checkpoint: what the checkpoint itself holds
        scalars, ranges = {}, []
    iteration = int(checkpoint["iter"])
    # the run may have logged past the exported checkpoint: the lineage ends at it
    ranges = [{**span, "last_iteration": min(span["last_iteration"], iteration)}
              for span in ranges if span["first_iteration"] <= iteration]

    def upto(tag: str) -> np.ndarray:
        steps, values = scalars.get(tag, (np.zeros(0), np.zeros(0)))
        return values[steps <= iteration]

    compute = checkpoint["infos"].get("compute_time_s")  # wall clock, kept across resumes
    if compute is None:  # older checkpoints: the logged iterations' times
        compute = float(upto("Perf/collection_time").sum() + upto("Perf/learning_time").sum())
    segments = checkpoint["infos"].get("segments") or [{"iteration": 0, "hardware": hardware()}]
    by_pose = sorted(t for t in scalars if t.startswith(("pose_success/", "pose_stood_up/")))
    final = {tag: float(np.mean(upto(tag)[-FINAL_WINDOW:]))
             for tag in [t for t, _ in CURVES] + by_pose if len(upto(tag))}
    return {
        "variant": meta["variant"], "git_commit": meta["git_commit"],
        "iteration": iteration, "env_steps": checkpoint["infos"].get("env_steps"),
        "compute_time_s": round(compute, 2),
        "hardware": segments[-1]["hardware"],
        "segments": segments,
        "train_config": meta["train_config"],
        "env_config": meta.get("env_config"),
        "amendments": meta.get("amendments", []),
        "curriculum": _without_outcomes(checkpoint["infos"].get("curriculum")),
        "assist": _without_outcomes(checkpoint["infos"].get("assist")),
        FINAL_KEY: final,
        "origin": "from scratch" if not history and not meta.get("amendments") else
                  "a fork or an amended run",
        **({"lineage": ranges} if history else {}),
        **_stages_upto(run_dir, iteration),
    }


def _stages_upto(run_dir: str | Path, iteration: int) -> dict:
    """A staged run's stage changes, probes and recordings up to ``iteration`` (its
    ``stages.json`` may already be further): ``{"stages": {...}}``, or nothing."""
    state = StageState.load(run_dir)
    if state is None:
        return {}
    changes = [c for c in state.changes if c["iteration"] <= iteration]
    return {"stages": {
        "stage": changes[-1]["to"] if changes else STAGES[0], "changes": changes,
        "probes": [p for p in state.probes if p["iteration"] <= iteration],
        "recordings": [r for r in state.recordings if r["iteration"] <= iteration]}}


def _without_outcomes(state: dict | None) -> dict | None:
    return None if state is None else {k: v for k, v in state.items() if k != "outcomes"}


WINDOW = 10
"""Iterations in the running mean of every panel but the per-pose one."""

POSE_WINDOW = 100
"""Iterations in the running mean of the per-pose panel: a pose's rate is the mean of the
few of its episodes that end in one iteration, and seven poses share the panel."""


def _draw(ax, scalar: tuple[np.ndarray, np.ndarray], per_iteration: int, window: int = WINDOW,
          **style) -> None:
    """One scalar against env steps [millions], as a running mean of ``window`` iterations."""
    steps, values = scalar
    k = min(window, len(values))
    smooth = np.convolve(values, np.ones(k) / k, mode="valid")
    ax.plot(steps[k - 1:] * per_iteration / 1e6, smooth, lw=1.4, **style)


Lineage = str | Path | Sequence[str | Path]
"""A run directory, or a fork with the runs it descends from, oldest first."""


def plot_curves(runs: str | Path | Mapping[str, Lineage], out: str | Path,
                title: str | None = None, upto: int | None = None,
                curves: Sequence[tuple[str, str]] = CURVES, by_pose: bool = True,
                since: int | None = None) -> Path:
    """Writes learning curves against env steps as a PNG.

    Args:
        runs: one run directory, or label → run directory to compare runs on one figure
            (a list of directories, oldest first, draws a fork from its lineage's root).
        out: the PNG path.
        title: figure title (default: the runs and their sizes).
        upto: draw iterations ≤ upto only (an exported checkpoint's curves).
        since: draw iterations ≥ since only (forks of a run, from the fork on).
        curves: (TensorBoard tag, panel title) of each panel (default :data:`CURVES`).
        by_pose: add a last panel with the first run's stood-up rates by start pose.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if isinstance(runs, str | Path):
        runs = {Path(runs).name: runs}
    out = Path(out)
    panels = [*curves, *([("pose_stood_up/", "stood up, by start pose")] if by_pose else [])]
    rows = -(-len(panels) // 3)
    fig, axes = plt.subplots(rows, 3, figsize=(13, 3.2 * rows), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, (_, label) in zip(axes.flat, panels, strict=False):
        ax.set_title(label, fontsize=9)
        ax.set_xlabel("env steps [millions]", fontsize=8)
        ax.grid(alpha=0.3)
    from hybrid_recovery.training.checkpoint import read_run_config

    sizes = []
    for index, (name, run) in enumerate(runs.items()):
        lineage = [run] if isinstance(run, str | Path) else list(run)
        run_dir = lineage[-1]
        scalars = read_lineage(lineage)
        lo, hi = -np.inf if since is None else since, np.inf if upto is None else upto
        kept = {tag: (steps >= lo) & (steps <= hi) for tag, (steps, _) in scalars.items()}
        scalars = {tag: (steps[kept[tag]], values[kept[tag]])  # tags logged in the window
                   for tag, (steps, values) in scalars.items() if kept[tag].any()}
        meta = read_run_config(run_dir)  # a damaged file is named
        config = meta["train_config"]
        per_iteration = config["num_envs"] * config["num_steps_per_env"]
        sizes.append(f"{name}: {config['num_envs']} envs")

        for ax, (tag, _) in zip(axes.flat, curves, strict=False):
            if tag in scalars:  # one colour per run in every panel
                _draw(ax, scalars[tag], per_iteration, label=name, color=f"C{index}")
        pose_tags = sorted(t for t in scalars if t.startswith("pose_stood_up/"))
        last = axes.flat[len(panels) - 1]
        if by_pose and pose_tags and not last.lines:  # the first run that logs them
            last.set_title(f"stood up, by start pose ({name})", fontsize=9)
            for k, tag in enumerate(pose_tags):
                _draw(last, scalars[tag], per_iteration, window=POSE_WINDOW,
                      label=tag.split("/")[1], color=f"C{k}")
        for number, amendment in enumerate(meta.get("amendments", []), 1):
            if not lo <= amendment["iteration"] <= hi:
                continue
            x = amendment["iteration"] * per_iteration / 1e6
            for ax in axes.flat[:len(panels)]:
                ax.axvline(x, color=f"C{index}", ls=":", lw=1)
            axes.flat[0].annotate(f"A{number}", (x, 1.0), xycoords=("data", "axes fraction"),
                                  fontsize=7, ha="center", va="bottom", color=f"C{index}")
    for ax in axes.flat:
        if ax.lines:
            ax.legend(fontsize=7)
    fig.suptitle((title or "; ".join(sizes)) + f" (mean of {WINDOW} iterations"
                 + (f", {POSE_WINDOW} by start pose" if by_pose else "")
                 + "; A<n>: the run's amendments, see its config.json)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return out
