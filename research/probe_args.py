"""Command-line arguments shared by the bridge probes of this folder."""

from __future__ import annotations

import argparse
from pathlib import Path


def bridge_probe_parser(description: str) -> argparse.ArgumentParser:
    """Arguments of the bridge probes: runs, --levels K, --envs, --source, --target, --seed."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--levels", type=int, default=8)
    parser.add_argument("--envs", type=int, default=64, help="episodes per level and run")
    parser.add_argument("--source", default="half_kneeling")
    parser.add_argument("--target", default="kneeling")
    parser.add_argument("--seed", type=int, default=7)
    return parser
