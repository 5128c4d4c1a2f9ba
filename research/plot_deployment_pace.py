"""Deployment stand-up rates of a lineage's checkpoints against env steps, per pose.

Each EVAL_DIR is the output of one ``hybrid-recovery eval --protocol poses`` of one
exported checkpoint (``hybrid-recovery export RUN --checkpoint …``): the header of its
``results.jsonl`` names the checkpoint's iteration and env steps. Arms are
``LABEL=DIR[,DIR …]``, one line each; per pose it draws the success rate with its 95 %
Wilson interval against env steps since ``--origin`` (an eval directory of the checkpoint
the recorded rises came in at, so that the old lineage's checkpoints lie left of 0; for a
run from nothing its iteration 0), and dotted lines at the milestones (50 %, 80 %, the
paper's 93.4 %). Prints a Markdown table.

    python research/plot_deployment_pace.py old=results/shipped,results/12650 \\
        control=results/c13950,results/c14450 teacher=results/t14300,results/t14575 \\
        --origin results/12650 --poses sitting supine --out deployment_pace.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

from hybrid_recovery.evaluation.overlay import rate_with_interval
from hybrid_recovery.evaluation.runner import HEADER_KEY, load_results

MILESTONES = (0.5, 0.8, 0.934)
"""Stand-up rates the learned stand-up aims at; the last is the paper's (§IV-A)."""


def checkpoint_rates(eval_dir: str | Path) -> dict:
    """``iteration``, ``env_steps`` and per pose (p, lower, upper, successes, trials) of
    one evaluated checkpoint.

    Raises:
        ValueError: the results' header names no policy with env steps (a controller
            other than an exported checkpoint).
    """
    rows = load_results(Path(eval_dir) / "results.jsonl")
    header = next((r for r in rows if r.get("key") == HEADER_KEY), {})
    policy = header.get("policy") or {}
    if policy.get("env_steps") is None:
        raise ValueError(f"{eval_dir}: the results' header names no checkpoint with env "
                         "steps (evaluate an exported checkpoint: --controller onnx:PATH)")
    trials = [r for r in rows if r.get("key") != HEADER_KEY]
    poses = sorted({r["pose"] for r in trials})
    return {"iteration": int(policy["iteration"]), "env_steps": int(policy["env_steps"]),
            "poses": {p: rate_with_interval([r for r in trials if r["pose"] == p])
                      for p in poses}}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("arms", nargs="+", help="LABEL=EVAL_DIR[,EVAL_DIR …], one per line")
    p.add_argument("--origin", type=Path, required=True,
                   help="eval directory of the checkpoint the rises came in at (x = 0)")
    p.add_argument("--poses", nargs="+", default=None, help="panels (default: every pose)")
    p.add_argument("--out", type=Path, required=True, help="the PNG")
    args = p.parse_args()
    origin = checkpoint_rates(args.origin)["env_steps"]
    arms = {}
    for item in args.arms:
        label, dirs = item.split("=", 1)
        arms[label] = sorted((checkpoint_rates(d) for d in dirs.split(",")),
                             key=lambda c: c["env_steps"])
    poses = args.poses or sorted({p for cks in arms.values() for c in cks for p in c["poses"]})

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(poses), figsize=(6 * len(poses), 4), squeeze=False)
    for j, pose in enumerate(poses):
        ax = axes[0, j]
        for k, (label, cks) in enumerate(arms.items()):
            cks = [c for c in cks if pose in c["poses"]]
            x = [(c["env_steps"] - origin) / 1e6 for c in cks]
            rate = [c["poses"][pose][0] for c in cks]
            err = [[r - c["poses"][pose][1] for r, c in zip(rate, cks, strict=True)],
                   [c["poses"][pose][2] - r for r, c in zip(rate, cks, strict=True)]]
            ax.errorbar(x, rate, yerr=err, color=f"C{k}", marker="o", ms=4, lw=1.2,
                        capsize=2, label=label)
        for level in MILESTONES:
            ax.axhline(level, color="grey", ls=":", lw=0.8)
        ax.axvline(0.0, color="grey", ls="--", lw=0.8)
        ax.set_title(pose)
        ax.set_xlabel("M env steps from the first iteration" if origin == 0
                      else "M env steps since the recorded rises came in")
        ax.set_ylabel("stand-up rate at deployment (95 % CI)")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=70)
    print("| arm | iteration | M env steps since | " + " | ".join(poses) + " |")
    print("|---|---|---|" + "---|" * len(poses))
    for label, cks in arms.items():
        for c in cks:
            cells = [f"{c['poses'][p][3]}/{c['poses'][p][4]} ({100 * c['poses'][p][0]:.1f} %)"
                     if p in c["poses"] else "–" for p in poses]
            print(f"| {label} | {c['iteration']} | {(c['env_steps'] - origin) / 1e6:+.1f} | "
                  + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
