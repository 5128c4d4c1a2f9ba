"""``hybrid-recovery export``."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.registry import command


def _export(args: argparse.Namespace) -> int:
    from hybrid_recovery.training.export import export_policy

    out = export_policy(args.run_dir, args.out, args.checkpoint, args.history)
    names = ["policy.onnx", "policy.json", "training_record.json",
             *(["curves.png"] if (out / "curves.png").is_file() else [])]
    print(f"wrote {', '.join(names[:-1])} and {names[-1]} to {out}")
    return 0


def _configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", help="training run directory")
    p.add_argument("--out", default=None, help="output directory (default RUN_DIR/export)")
    p.add_argument("--checkpoint", default=None, help="a checkpoint file (default latest.pt)")
    p.add_argument("--history", nargs="+", default=[], metavar="RUN_DIR",
                   help="the runs RUN_DIR was forked from, oldest first: the training "
                        "record's curves and figures then cover the whole lineage")


_export.configure = _configure  # type: ignore[attr-defined]
command("export", "Export a run's policy to ONNX with its policy.json.")(_export)
