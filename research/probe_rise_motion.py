"""How runs' actors move from each level of a start-pose bridge: deterministic, unassisted
episodes as in ``probe_bridge_levels.py``, with per episode the feet's highest lift and
furthest forward travel relative to the CoM, the knees' lift, the most upright shin (the
largest z component of either shin's ankle→knee axis, r_shin's s_z: −0.2 kneeling, ≈ 1
standing), the CoM's furthest travel ahead of and behind its start, the time of the peak
CoM height, the episode's length and how it ended; medians over stood-up and failed
episodes. Forward is the robot's heading at the start (its pelvis x axis, horizontal),
which the starts draw at random.

    python research/probe_rise_motion.py runs/my_run --levels 8 --at 3 4 8 --envs 64
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import torch
from bridge_args import bridge_parser

from hybrid_recovery.training.probe import (
    bridge_env,
    ended_episodes,
    heading_xy,
    start_episodes,
)


def _medians(rows: dict[str, np.ndarray], mask: np.ndarray) -> dict[str, float] | None:
    if not mask.any():
        return None
    return {key: round(float(np.median(value[mask])), 3) for key, value in rows.items()}


def motion(run: Path, levels: int, at: list[int], num_envs: int, seed: int, source: str,
           target: str) -> dict:
    """Per probed level: the stood-up share, the end reasons and the motion medians."""
    env, actor, data = bridge_env(run, num_envs, seed, levels, source, target)
    feet, knees = env.feet, env.knees
    xpos = env.sims.bind("xpos")
    out = {"run": str(run), "iteration": int(data["iter"]), "episodes": num_envs, "levels": {}}
    for k in at:
        env.bridge.level[target] = k
        n = num_envs
        obs = start_episodes(env)
        done, stood = np.zeros(n, bool), np.zeros(n, bool)
        foot0, knee0 = xpos[:, feet].copy(), xpos[:, knees].copy()
        com0 = env._state["com"][:, :2].copy()
        heading = heading_xy(env.sims.bind("xmat")[:, 1])
        rows = {name: np.zeros(n) for name in ("foot_lift_m", "foot_forward_m", "knee_lift_m",
                                              "com_ahead_m", "com_behind_m", "peak_height_m",
                                              "peak_time_s", "length_s")}
        rows["shin_up"] = env._state["shin_up"].max(1)
        ends: dict[int, str] = {}
        step = 0
        while not done.all():
            with torch.no_grad():
                obs, _, dones, extras = env.step(actor(obs))
            step += 1
            live = ~done & ~dones.numpy()  # an episode ended by this step: its env is reset
            com = env._state["com"]
            lift = (xpos[:, feet, 2] - foot0[:, :, 2]).max(1)
            foot_rel = xpos[:, feet, :2] - com[:, None, :2] - (foot0[:, :, :2] - com0[:, None])
            forward = np.einsum("nfk,nk->nf", foot_rel, heading).max(1)
            travel = np.einsum("nk,nk->n", com[:, :2] - com0, heading)
            knee = (xpos[:, knees, 2] - knee0[:, :, 2]).max(1)
            higher = live & (com[:, 2] > rows["peak_height_m"])
            rows["peak_time_s"][higher] = step * env.dt
            for name, value in (("foot_lift_m", lift), ("foot_forward_m", forward),
                                ("knee_lift_m", knee), ("com_ahead_m", travel),
                                ("com_behind_m", -travel), ("peak_height_m", com[:, 2]),
                                ("shin_up", env._state["shin_up"].max(1))):
                rows[name][live] = np.maximum(rows[name][live], value[live])
            ended, up, causes = ended_episodes(dones, extras)
            first = ~done[ended]
            stood[ended[first]] = up[first]
            rows["length_s"][ended[first]] = step * env.dt
            for i, cause in zip(ended[first], np.array(causes, dtype=object)[first], strict=True):
                if cause:
                    ends[int(i)] = cause
            done[ended] = True
        out["levels"][f"{k}/{levels}"] = {
            "stood_up": round(float(stood.mean()), 3), "ended_by": dict(Counter(ends.values())),
            "stood_up_medians": _medians(rows, stood), "failed_medians": _medians(rows, ~stood)}
    return out


def main() -> None:
    parser = bridge_parser(__doc__.split("\n")[0])
    parser.add_argument("--at", type=int, nargs="+", default=[3, 4, 8],
                        help="levels to probe (K: the target pose itself)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    for run in args.runs:
        print(json.dumps(motion(run, args.levels, args.at, args.envs, args.seed, args.source,
                                args.target)), flush=True)


if __name__ == "__main__":
    main()
