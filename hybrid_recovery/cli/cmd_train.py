"""``hybrid-recovery train``."""

from __future__ import annotations

import argparse
from pathlib import Path

from hybrid_recovery.cli.registry import command, parse_overrides


def _train(args: argparse.Namespace) -> int:
    from hybrid_recovery.training import train
    from hybrid_recovery.training.variants import variant_train_config

    try:
        cfg = variant_train_config(
            args.variant, num_envs=args.num_envs, iterations=args.iterations, seed=args.seed,
            save_interval=args.save_interval, num_threads=args.threads,
            init_std=args.init_std, max_std=args.max_std,
            env_overrides=parse_overrides(args.set) or None)
    except KeyError as err:
        raise SystemExit(err.args[0]) from None
    if args.symmetry:
        cfg.ppo.symmetry = True
    run_dir = Path(args.run_dir or f"runs/{args.variant}")
    train(run_dir, cfg, resume=args.resume, amend=parse_overrides(args.amend))
    return 0


def _configure_train(p: argparse.ArgumentParser) -> None:
    p.add_argument("--variant", default="full",
                   help="recovery (the shipped policy's recipe) | full (the paper's) | reduced "
                        "| no_privileged | no_capture_point | no_curriculum")
    p.add_argument("--num-envs", type=int, default=None, help="default 1024")
    p.add_argument("--iterations", type=int, default=None,
                   help="total PPO iterations of the run (default: the paper's 50,000)")
    p.add_argument("--seed", type=int, default=None, help="default 0")
    p.add_argument("--save-interval", type=int, default=None,
                   help="default 50 (recovery: 25)")
    p.add_argument("--threads", type=int, default=None, help="default 2")
    p.add_argument("--run-dir", default=None, help="default: runs/<variant>")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --run-dir with its saved settings")
    p.add_argument("--symmetry", action="store_true", help="left/right mirror augmentation")
    p.add_argument("--init-std", type=float, default=None,
                   help="initial action noise std (the paper: 1.0; recovery: 0.5)")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="EnvConfig overrides, e.g. rewards.w_cp=0 curriculum.window=256")
    p.add_argument("--amend", nargs="*", default=[], metavar="KEY=VALUE",
                   help="with --resume: change the run's saved settings from now on, e.g. "
                        "ppo.entropy_coef=0.001 train.max_std=0.4 rewards.w_cp=0 (kept in "
                        "config.json)")
    p.add_argument("--max-std", type=float, default=None,
                   help="upper bound of the action noise std (default: unbounded; "
                        "recovery: 0.6)")


_train.configure = _configure_train  # type: ignore[attr-defined]
command("train", "Train the recovery policy with PPO (rsl-rl-lib).")(_train)
