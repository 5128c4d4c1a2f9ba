"""``hybrid-recovery export``."""

from __future__ import annotations

import argparse

from hybrid_recovery.cli.registry import command


def _export(args: argparse.Namespace) -> int:
    from hybrid_recovery.training.export import EXPORTED_FILES, export_policy

    out = export_policy(args.run_dir, args.out, args.checkpoint, args.history,
                        force=args.force)
    names = [name for name in EXPORTED_FILES if (out / name).is_file()]
    print(f"wrote {', '.join(names[:-1])} and {names[-1]} to {out}")
    return 0


def _configure(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", help="training run directory")
    p.add_argument("--out", default=None, help="output directory (default RUN_DIR/export)")
    p.add_argument("--checkpoint", default=None, help="a checkpoint file (default latest.pt)")
    p.add_argument("--history", nargs="+", default=[], metavar="RUN_DIR",
                   help="the runs RUN_DIR was forked from, oldest first: the training "
                        "record's curves and figures then cover the whole lineage")
    p.add_argument("--force", action="store_true",
                   help="replace an exported policy already in the output directory")


_export.configure = _configure  # type: ignore[attr-defined]
command("export", "Export a run's policy to ONNX with its policy.json.")(_export)
