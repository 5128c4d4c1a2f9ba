"""A/B of PPO update settings at equal env steps: learning curves from scratch.

Trains the same variant from scratch once per (setting, seed), each run to the same
number of iterations (so the same env steps), the settings differing only in the PPO
update (``ppo.<field>``), then draws every run's curves on one figure (mean over seeds,
each seed faint) and prints a Markdown table of the last ``--window`` iterations. Runs
already finished are kept; a killed one resumes. Seeds outer, settings inner, so an
interrupted A/B stays balanced.

    python research/ab_update.py --root runs/ab_update --seeds 0 1 2 --iterations 100 \\
        --out docs/update_ab.png
    python research/ab_update.py --root runs/ab_update --seeds 0 1 2 --plot-only ...
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from hybrid_recovery.cli.main import OMP_WAIT_POLICY
from hybrid_recovery.training.record import read_scalars

SETTINGS: dict[str, dict[str, object]] = {
    "5 epochs, fp32": {"num_learning_epochs": 5, "mixed_precision": False},
    "2 epochs, fp32": {"num_learning_epochs": 2, "mixed_precision": False},
    "5 epochs, bf16": {"num_learning_epochs": 5, "mixed_precision": True},
    "4 epochs, bf16": {"num_learning_epochs": 4, "mixed_precision": True},
    "3 epochs, bf16": {"num_learning_epochs": 3, "mixed_precision": True},
}
"""The compared update settings: label → PPOConfig fields."""

TAGS: tuple[tuple[str, str], ...] = (
    ("Train/mean_reward", "mean episode reward"),
    ("episode/stood_up", "stood up"),
    ("Train/mean_episode_length", "mean episode length [steps]"),
    ("Policy/mean_std", "action noise std"),
)


def run_dir(root: Path, label: str, seed: int) -> Path:
    slug = label.replace(", ", "_").replace(" ", "")
    return root / f"{slug}_seed{seed}"


def train_one(root: Path, label: str, seed: int, args: argparse.Namespace) -> None:
    from hybrid_recovery.training import train
    from hybrid_recovery.training.checkpoint import load_latest
    from hybrid_recovery.training.variants import variant_train_config

    cfg = variant_train_config(args.variant, num_envs=args.num_envs,
                               iterations=args.iterations, seed=seed,
                               num_threads=args.threads, save_interval=25)
    for key, value in SETTINGS[label].items():
        setattr(cfg.ppo, key, value)
    out = run_dir(root, label, seed)
    resume = (out / "latest.pt").is_file()
    if resume and int(load_latest(out)[0]["iter"]) + 1 >= args.iterations:
        return
    print(f"[ab_update] {label}, seed {seed} → {out}", flush=True)
    train(out, cfg, resume=resume, force=not resume)


def curves(root: Path, label: str, seeds: list[int]) -> dict[str, list[np.ndarray]]:
    out: dict[str, list[np.ndarray]] = {tag: [] for tag, _ in TAGS}
    for seed in seeds:
        d = run_dir(root, label, seed)
        if not d.is_dir():
            continue
        scalars = read_scalars(d)
        for tag, _ in TAGS:
            if tag in scalars:
                out[tag].append(scalars[tag][1])
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--root", type=Path, required=True)
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    p.add_argument("--variant", default="recovery")
    p.add_argument("--iterations", type=int, default=100)
    p.add_argument("--num-envs", type=int, default=1024)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--window", type=int, default=20, help="iterations of the table")
    p.add_argument("--plot-only", action="store_true")
    p.add_argument("--out", type=Path, required=True, help="the PNG")
    args = p.parse_args()

    os.environ.setdefault("OMP_WAIT_POLICY", OMP_WAIT_POLICY)  # as the CLI: before torch
    if not args.plot_only:
        for seed in args.seeds:
            for label in args.settings:
                train_one(args.root, label, seed, args)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps_per_it = args.num_envs * 24
    fig, axes = plt.subplots(1, len(TAGS), figsize=(4.2 * len(TAGS), 3.6))
    print(f"| setting | seeds | {' | '.join(name for _, name in TAGS)} |")
    print("|---|---|" + "---|" * len(TAGS))
    for i, label in enumerate(args.settings):
        data = curves(args.root, label, args.seeds)
        cells = []
        for ax, (tag, name) in zip(axes, TAGS, strict=True):
            runs = data[tag]
            if not runs:
                cells.append("–")
                continue
            n = min(len(r) for r in runs)
            stack = np.stack([r[:n] for r in runs])
            x = np.arange(n) * steps_per_it / 1e6
            for r in stack:
                ax.plot(x, r, color=f"C{i}", alpha=0.25, lw=0.8)
            ax.plot(x, stack.mean(0), color=f"C{i}", lw=1.8, label=label)
            ax.set_title(name, fontsize=10)
            ax.set_xlabel("env steps [M]")
            last = stack[:, -args.window:].mean(1)
            cells.append(f"{last.mean():.3g} ± {last.std():.2g}")
        print(f"| {label} | {len(data[TAGS[0][0]])} | {' | '.join(cells)} |")
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend(fontsize=8)
    fig.suptitle(f"PPO update settings from scratch ({args.variant}, {args.num_envs} envs, "
                 f"seeds {' '.join(map(str, args.seeds))}; thick: mean over seeds)",
                 fontsize=10)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=72)
    print(json.dumps({"figure": str(args.out)}))


if __name__ == "__main__":
    main()
