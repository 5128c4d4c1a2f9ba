"""``hybrid-recovery train``."""

from __future__ import annotations

import argparse
from pathlib import Path

from hybrid_recovery.cli.errors import UsageError
from hybrid_recovery.cli.registry import command, parse_overrides
from hybrid_recovery.cli.validate import add_backend_options, integer, positive

DEFAULT_VARIANT = "full"


def _train(args: argparse.Namespace) -> int:
    from hybrid_recovery.training import train
    from hybrid_recovery.training.variants import variant_train_config

    settings = dict(num_envs=args.num_envs, iterations=args.iterations, seed=args.seed,
                    save_interval=args.save_interval, num_threads=args.threads,
                    torch_threads=args.torch_threads, init_std=args.init_std, max_std=args.max_std,
                    backend=args.backend, device=args.device,
                    env_overrides=parse_overrides(args.set) or None)
    variant = args.variant or DEFAULT_VARIANT
    try:
        cfg = variant_train_config(variant, **settings)
    except KeyError as err:
        raise UsageError(err.args[0]) from None
    if args.symmetry:
        cfg.ppo.symmetry = True
    if args.mixed_precision is not None:
        cfg.ppo.mixed_precision = args.mixed_precision
    if args.teacher_lr is not None:
        cfg.teacher.learning_rate = args.teacher_lr
    given = {name for name, value in settings.items() if value is not None}
    given |= {"teacher"} if args.teacher_lr is not None else set()
    given |= {"variant"} if args.variant else set()
    given |= {"ppo"} if args.symmetry or args.mixed_precision is not None else set()
    run_dir = Path(args.run_dir or f"runs/{variant}")
    options = dict(resume=args.resume, amend=parse_overrides(args.amend), force=args.force,
                   given=given)
    from hybrid_recovery.recipe.staged_run import is_staged_run, train_staged

    if is_staged_run(run_dir) if args.resume else cfg.stages is not None:
        train_staged(run_dir, cfg, **options)  # type: ignore[arg-type]
    else:
        train(run_dir, cfg, **options)  # type: ignore[arg-type]
    return 0


def _configure_train(p: argparse.ArgumentParser) -> None:
    p.add_argument("--variant", default=None,
                   help="recovery_rises (the recipe in stages: recovery, its own rises "
                        "recorded, starts along them and the teacher; training/README.md) | "
                        "recovery_model_rises (the same with the model-based half's rises) | "
                        "recovery (its first stage alone) | full (the "
                        "paper's, the default) | reduced | no_privileged | no_capture_point | "
                        "no_curriculum")
    p.add_argument("--num-envs", type=integer(1), default=None, help="default 1024")
    p.add_argument("--iterations", type=integer(1), default=None,
                   help="total PPO iterations of the run (default: the paper's 50,000; with "
                        "--resume the run's own)")
    p.add_argument("--seed", type=int, default=None, help="default 0")
    p.add_argument("--save-interval", type=integer(1), default=None,
                   help="default 50 (recovery: 25)")
    p.add_argument("--threads", type=integer(1), default=None,
                   help="physics threads, and torch threads unless --torch-threads is given "
                        "(default: the CPUs this process may run on)")
    p.add_argument("--torch-threads", type=integer(1), default=None,
                   help="torch threads for inference and the PPO update (default: --threads)")
    add_backend_options(p)
    p.add_argument("--run-dir", default=None, help="default: runs/<variant>")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --run-dir with its saved settings")
    p.add_argument("--force", action="store_true",
                   help="start over in a --run-dir that holds a run (its checkpoints, "
                        "settings and logs are removed)")
    p.add_argument("--symmetry", action="store_true", help="left/right mirror augmentation")
    p.add_argument("--mixed-precision", action=argparse.BooleanOptionalAction, default=None,
                   help="bf16 autocast for the PPO update, float32 weights and optimiser "
                        "(default: the faster of the two measured on this CPU at every "
                        "start and resume; recovery: off)")
    p.add_argument("--init-std", type=positive, default=None,
                   help="initial action noise std (the paper: 1.0; recovery: 0.5)")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="EnvConfig overrides, e.g. rewards.w_cp=0 curriculum.window=256")
    p.add_argument("--amend", nargs="*", default=[], metavar="KEY=VALUE",
                   help="with --resume: change the run's saved settings from now on, e.g. "
                        "ppo.entropy_coef=0.001 train.max_std=0.4 rewards.w_cp=0 (kept in "
                        "config.json)")
    p.add_argument("--teacher-lr", type=positive, default=None,
                   help="imitation of the recorded ground moves after each PPO update: the "
                        "Adam step size lr0, annealed to 0 over teacher.anneal_iterations "
                        "updates (needs rises.files with targets; default off)")
    p.add_argument("--max-std", type=positive, default=None,
                   help="upper bound of the action noise std (default: unbounded; "
                        "recovery: 0.6)")


_train.configure = _configure_train  # type: ignore[attr-defined]
command("train", "Train the recovery policy with PPO (rsl-rl-lib).")(_train)
