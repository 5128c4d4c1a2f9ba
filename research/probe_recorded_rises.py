"""Would the training env let a recorded rise happen? Per stretch of a recording's moves:
the share of its starts whose own recorded continuation stuck-low would end, and the share
of its samples with a joint beyond the training robot's joint ranges.

Every move sample r of a recording (``hybrid-recovery getup record``) is a start of the
recorded-rise curriculum (``rises.*``); its continuation is the move's samples r, r + 1,
… to the move's end at the control rate (50 Hz). Each continuation's CoM height h_c runs
through the env's own :class:`~hybrid_recovery.envs.terminations.StuckLow` with the
settings' ``stuck_time``, ``stuck_rise`` and ``upright_height``, as an episode that followed
the recording exactly would. The training robot's joint ranges are the model's scaled
about their middle by the curriculum's final ``position_limit_final`` (0.9, the paper's
§III-F); a sample beyond them is a posture that robot cannot take (a reset clips it in).
A share above 0 at a stretch says the curriculum asks the policy, from those starts, for
another rise than the one recorded (docs/experiments.md §12). Needs no run.

    python research/probe_recorded_rises.py runs/R/rises/sitting.npz --levels 16
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.envs import default_config
from hybrid_recovery.envs.config import EnvConfig, RiseConfig
from hybrid_recovery.envs.rise_starts import RiseStarts
from hybrid_recovery.envs.terminations import StuckLow
from hybrid_recovery.getup.relapse import com_height
from hybrid_recovery.robot.constants import JOINT_NAMES
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses
from hybrid_recovery.sim.scene import build_scene


def com_heights(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """CoM height above z = 0 of each state (M, nq) → (M,) [m] (flat ground)."""
    data = mujoco.MjData(model)
    heights = np.empty(len(qpos))
    for i, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        heights[i] = com_height(model, data)
    return heights


def stuck_on_continuations(heights: np.ndarray, last: np.ndarray, cfg: EnvConfig, dt: float
                           ) -> np.ndarray:
    """The time [s] at which stuck-low ends each start's recorded continuation, NaN where
    it never does before the move's end.

    Args:
        heights: h_c of every move sample (M,) [m], in the order of ``last``.
        last: each sample's move's last sample (M,) int (≥ its own index).
    """
    rows = np.arange(len(heights))
    stuck = StuckLow(len(rows), cfg.stuck_time, cfg.stuck_rise, dt)
    stuck.reset(rows, heights)
    ended = np.full(len(rows), np.nan)
    for step in range(1, int((last - rows).max()) + 1):
        moving = rows + step <= last
        if not moving.any():
            break
        h = heights[np.minimum(rows + step, last)]
        fired = stuck.update(h, dt, h < cfg.upright_height) & moving & np.isnan(ended)
        ended[fired] = step * dt
    return ended


def beyond_ranges(model: mujoco.MjModel, qpos: np.ndarray, factor: float) -> np.ndarray:
    """How far each state's (M, nq) actuated joints (motor order) lie beyond the model's
    ranges scaled about their middle by ``factor``, (M, 27) [rad] (≤ 0: within)."""
    lo, hi = SafetyLimits.from_model(model).q_ref_bounds(factor)
    q = qpos[:, joint_addresses(model)[0]]
    return np.maximum(lo - q, q - hi)


def probe(path: Path, levels: int, cfg: EnvConfig | None = None) -> dict:
    """Per stretch k (0 ending at the hand-over, K − 1 beginning at the ground pose) of
    ``path``'s moves: the starts, the share stuck-low ends and the median time it does,
    the share of samples with a joint beyond the training ranges (more than 1 mrad), the
    largest excess and the joint beyond them most often."""
    cfg = cfg or default_config()
    model, _ = build_scene(cfg.model_path, cfg.physics_dt)
    rises = RiseStarts(RiseConfig(files=(str(path),), levels=levels), model.nq, model.nv)
    (pose,) = rises.poses
    moves = rises.moves[pose]
    dt = cfg.physics_dt * cfg.decimation
    ended = stuck_on_continuations(com_heights(model, moves.qpos),
                                   np.arange(len(moves.remaining)) + moves.remaining, cfg, dt)
    factor = cfg.curriculum.position_limit_final
    excess = beyond_ranges(model, moves.qpos, factor)
    table = {}
    for k in range(levels - 1, -1, -1):
        here = moves.stretch == k
        mine, over = ended[here], excess[here] > 1e-3
        hit = ~np.isnan(mine)
        table[str(k)] = {"starts": int(len(mine)), "stuck_share": round(float(hit.mean()), 3),
                         "median_time_s": round(float(np.median(mine[hit])), 2)
                         if hit.any() else None,
                         "beyond_range_share": round(float(over.any(axis=1).mean()), 3),
                         "largest_excess_rad": round(float(excess[here].max()), 3),
                         "most_often_beyond": JOINT_NAMES[int(over.mean(axis=0).argmax())]
                         if over.any() else None}
    return {"recording": str(path), "pose": pose, "levels": levels,
            "stuck_time": cfg.stuck_time, "stuck_rise": cfg.stuck_rise,
            "range_factor": factor, "by_stretch": table}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("recordings", type=Path, nargs="+")
    parser.add_argument("--levels", type=int, default=16, help="K, as the run's rises.levels")
    args = parser.parse_args()
    for path in args.recordings:
        print(json.dumps(probe(path, args.levels)), flush=True)


if __name__ == "__main__":
    main()
