"""Probe: which way a controller rises from the ground: through hands and knees or not.

For each (pose, seed) start of the evaluation (``Scenario(pose, seed)``) the controller
runs until it has stood (the success criterion held 1 s) or the trial ends; at every
sample (50 Hz) the named floor contacts (:func:`~hybrid_recovery.getup.contact_map.
floor_contacts`), the pelvis height z_p and the z of the pelvis's up axis are read.
Per trial: stood and the time to stand; the time on hands and knees (both hands and a
knee on the floor, no sole flat: toes may touch); the time with no part of either sole
on the floor while z_p < 0.5 m (turning or tumbling on the ground); the time with
nothing on the floor (in flight); the lowest up-axis z
(< 0: the pelvis turned past horizontal); and the time on the feet alone before
standing (from the last sample with anything but a sole on the floor).

    python research/probe_rise_path.py --controller learned --poses sitting supine --seeds 0:10
    python research/probe_rise_path.py --controller model --poses sitting supine --seeds 0:10
"""

from __future__ import annotations

import argparse
from multiprocessing import Pool

import mujoco
import numpy as np

from hybrid_recovery.controllers.registry import make
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import RECORD_DT, run_trial
from hybrid_recovery.getup.contact_map import floor_contacts
from hybrid_recovery.robot.constants import PELVIS_BODY

_HANDS = {"left_hand", "right_hand"}
_KNEES = {"left_knee", "right_knee"}
_FLAT = {f"{side}_{part}" for side in ("left", "right") for part in ("foot", "heel")}
_SOLES = _FLAT | {"left_toes", "right_toes"}


def sample_of(model: mujoco.MjModel, data: mujoco.MjData
              ) -> tuple[float, float, bool, bool, bool, bool]:
    """(z_p [m], the pelvis up axis's z, on hands and knees, no sole on the floor,
    anything but a sole on the floor, nothing on the floor) of a forwarded state (module
    docstring)."""
    named, unmapped = floor_contacts(model, data)
    touching = set(named) | set(unmapped)
    on_hands_knees = _HANDS <= touching and bool(_KNEES & touching) and not (_FLAT & touching)
    pelvis = model.body(PELVIS_BODY).id
    return (float(data.xpos[pelvis, 2]), float(data.xmat[pelvis, 8]), on_hands_knees,
            not (_SOLES & touching), bool(touching - _SOLES), not touching)


def path_of(controller: str, pose: str, seed: int, duration: float = 20.0) -> dict:
    """The measures of the module docstring for one trial."""
    rows: list[tuple[float, float, bool, bool, bool, bool]] = []
    out = run_trial(make(controller), Scenario(pose, duration=duration, seed=seed),
                    on_sample=lambda model, data, _force: rows.append(sample_of(model, data)),
                    stop_on_success=True)
    z, up, hands_knees, soles_off, grounded, flight = (np.array(c)
                                                       for c in zip(*rows, strict=True))
    stood = bool(out["success"])
    t_stand = float(out["recovery_time"]) if stood else float("nan")
    on_ground = np.flatnonzero(grounded)
    left_ground = (on_ground[-1] + 1) * RECORD_DT if len(on_ground) else 0.0
    return {"pose": pose, "seed": seed, "stood": stood, "time": t_stand,
            "hands_knees": float(hands_knees.sum() * RECORD_DT),
            "soles_off_low": float((soles_off & (z < 0.5)).sum() * RECORD_DT),
            "flight": float(flight.sum() * RECORD_DT),
            "min_up": float(up.min()),
            "on_feet": t_stand - left_ground if stood else float("nan")}


def probe(controller: str, poses: list[str], seeds: range, workers: int = 1,
          duration: float = 20.0) -> list[dict]:
    """:func:`path_of` for every (pose, seed), in ``workers`` processes."""
    jobs = [(controller, pose, seed, duration) for pose in poses for seed in seeds]
    if workers <= 1:
        return [path_of(*job) for job in jobs]
    with Pool(workers) as pool:
        return pool.starmap(path_of, jobs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", default="learned",
                        help="a controller name or onnx:PATH (`hybrid-recovery eval --help`)")
    parser.add_argument("--poses", nargs="+", default=["sitting", "supine"])
    parser.add_argument("--seeds", default="0:10", help="first:end (end excluded)")
    parser.add_argument("--duration", type=float, default=20.0, help="trial length [s]")
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    first, end = (int(x) for x in args.seeds.split(":"))
    rows = probe(args.controller, args.poses, range(first, end), args.workers, args.duration)
    print("pose      seed stood time[s] hands&knees[s] soles-off-low[s] flight[s] min-up "
          "on-feet[s]")
    for r in rows:
        print(f"{r['pose']:9s} {r['seed']:4d} {r['stood']!s:5s} {r['time']:7.2f} "
              f"{r['hands_knees']:14.2f} {r['soles_off_low']:16.2f} {r['flight']:9.2f} "
              f"{r['min_up']:+6.2f} {r['on_feet']:10.2f}")
    for pose in args.poses:
        mine = [r for r in rows if r["pose"] == pose]
        stood = [r for r in mine if r["stood"]]
        on_feet = np.median([r["on_feet"] for r in stood]) if stood else float("nan")
        print(f"{pose}: stood {len(stood)}/{len(mine)}; median over all: hands and knees "
              f"{np.median([r['hands_knees'] for r in mine]):.2f} s, soles off while low "
              f"{np.median([r['soles_off_low'] for r in mine]):.2f} s, in flight "
              f"{np.median([r['flight'] for r in mine]):.2f} s, lowest up-axis z "
              f"{np.median([r['min_up'] for r in mine]):+.2f}; over those that stood: time "
              f"{np.median([r['time'] for r in stood]) if stood else float('nan'):.2f} s, "
              f"on the feet alone {on_feet:.2f} s")


if __name__ == "__main__":
    main()
