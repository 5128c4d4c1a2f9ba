"""The command-line arguments shared by the start-pose bridge probes."""

from __future__ import annotations

import argparse
from pathlib import Path


def bridge_parser(description: str) -> argparse.ArgumentParser:
    """Runs, --levels K, --envs, --source, --target, --seed; each script adds its own."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--levels", type=int, default=8)
    parser.add_argument("--envs", type=int, default=64, help="episodes per level and run")
    parser.add_argument("--source", default="half_kneeling")
    parser.add_argument("--target", default="kneeling")
    parser.add_argument("--seed", type=int, default=7)
    return parser
