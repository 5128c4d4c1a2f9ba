"""Probe: hands and knees → squat, then the QP's rise, from the model controller's own
hand-over states.

Each (pose, seed) start of the evaluation (``Scenario(pose, seed)``) runs under
``--controller model`` until hands and knees → squat begins (after the kneel move's or
the ground chain's push-up); that state (qpos, qvel, time, the move's pace) is kept in
``--states`` (an ``.npz``, reused when present). From each kept state the probe then
runs :class:`hybrid_recovery.getup.to_squat.ToSquat` alone at the controller's pace,
offers the squat to :meth:`BalanceController.rise` every 20 ms for up to 1 s after the
move's end (the controller: every 2 ms, up to ``rise_wait``), and runs an accepted
rise ``--rise`` seconds: it stood when the CoM is then above 0.85 m. Per pose: squats the
rise accepted, stood, and their 95 % Wilson intervals. The replays leave out the chaos of
the moves before the hand-over (``docs/experiments.md`` §15): a change to the to-squat or
the rise is compared on the same states.

``--servo`` asks whether the move can be carried by the policy's interface, joint PD
(τ = K_P (q_ref − q) − K_D q̇, q_ref within the ranges × 0.9) in place of the QP's torques,
before its states are labelled for the teacher (``training/teacher.py``): ``keyframe``
servos to the stage's keyframe q_g (the label a* of a joint-PD ground move); ``inverse``
to the target that gives the QP's torque, q_ref = q + (τ_QP + K_D q̇) / K_P, refreshed
every ``--servo-every`` physics steps (10: 50 Hz, the policy's rate) and held between.

    python research/probe_to_squat.py --poses kneeling sitting supine --seeds 0:20
    python research/probe_to_squat.py --poses sitting supine --seeds 0:20 --servo inverse
"""

from __future__ import annotations

import argparse
from multiprocessing import Pool
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.control.balance_controller import BalanceController
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.torque_model import CONTROL_DT
from hybrid_recovery.controllers.model import ModelController
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.success import wilson_interval
from hybrid_recovery.evaluation.trial import eval_model, run_trial
from hybrid_recovery.getup.relapse import com_height
from hybrid_recovery.getup.to_squat import ToSquat, ToSquatConfig
from hybrid_recovery.robot.action import TARGET_RANGE_FACTOR
from hybrid_recovery.robot.constants import JOINT_NAMES, KD, KP
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses

_CHECK_EVERY = 10
"""Physics steps between the rise's checks of the squat (20 ms)."""
SERVOS = ("qp", "keyframe", "inverse")
"""What drives the joints during the move (module docstring)."""


class _HandOver(Exception):
    """Raised where hands and knees → squat starts, to end the trial there."""


def hand_over_state(pose: str, seed: int) -> dict | None:
    """qpos, qvel, time and time_scale where the model controller starts hands and knees →
    squat from ``Scenario(pose, seed)``; None if it never does within 20 s."""
    state: dict = {}
    reset = ToSquat.reset

    def keep(self: ToSquat, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        state.update(qpos=data.qpos.copy(), qvel=data.qvel.copy(), time=float(data.time),
                     time_scale=self.config.time_scale)
        raise _HandOver

    ToSquat.reset = keep  # type: ignore[method-assign]
    try:
        run_trial(ModelController(), Scenario(pose, duration=20.0, seed=seed))
    except _HandOver:
        pass
    finally:
        ToSquat.reset = reset  # type: ignore[method-assign]
    return state or None


def replay(state: dict, rise_time: float, time_scale: float | None = None,
           servo: str = "qp", servo_every: int = 10, range_factor: float = 1.0) -> str:
    """``"stood"``, ``"fell"`` (the rise accepted the squat, the CoM ended at or below
    0.85 m) or ``"no_squat"`` from one kept state; the move at ``time_scale`` (None: the
    controller's pace kept with the state), its joints driven by ``servo`` (:data:`SERVOS`),
    the robot's joint ranges scaled about their middle by ``range_factor`` (0.9: the
    training robot's at the curriculum's end; a state beyond them is clipped in)."""
    model = eval_model(None, CONTROL_DT, True, "default")
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.time = state["qpos"], state["qvel"], state["time"]
    if range_factor != 1.0:
        scale_ranges(model, data, range_factor)
    qadr, dadr = joint_addresses(model)
    mujoco.mj_forward(model, data)
    pace = float(state["time_scale"]) if time_scale is None else time_scale
    move = ToSquat(ToSquatConfig(time_scale=pace))
    move.reset(model, data)
    lo, hi = SafetyLimits.from_model(model).q_ref_bounds(TARGET_RANGE_FACTOR)
    balance, steps, done_at, q_ref = BalanceController(), 0, None, None
    while True:
        tau = move(model, data)
        q, dq = data.qpos[qadr], data.qvel[dadr]
        if servo == "keyframe":
            q_ref = move.goal
        elif servo == "inverse" and steps % servo_every == 0:
            q_ref = q + (tau + KD * dq) / KP
        data.ctrl[:] = tau if servo == "qp" else pd_torque(np.clip(q_ref, lo, hi), q, dq)
        mujoco.mj_step(model, data)
        steps += 1
        if not move.done:
            continue
        done_at = float(data.time) if done_at is None else done_at
        if steps % _CHECK_EVERY == 0 and balance.rise(model, data):
            break
        if float(data.time) > done_at + 1.0:
            return "no_squat"
    end = float(data.time) + rise_time
    while float(data.time) < end:
        data.ctrl[:] = balance(model, data)
        mujoco.mj_step(model, data)
    return "stood" if com_height(model, data) > 0.85 else "fell"


def scale_ranges(model: mujoco.MjModel, data: mujoco.MjData, factor: float) -> None:
    """The actuated joints' ranges of ``model`` × ``factor`` about their middle, and
    ``data``'s joint positions clipped into them (in place; the free joint untouched)."""
    lo, hi = SafetyLimits.from_model(model).q_ref_bounds(factor)
    ids = [model.joint(name).id for name in JOINT_NAMES]
    model.jnt_range[ids] = np.stack([lo, hi], axis=1)
    qadr = joint_addresses(model)[0]
    data.qpos[qadr] = np.clip(data.qpos[qadr], lo, hi)


def _starmap(fn, jobs: list[tuple], workers: int) -> list:
    """``fn(*job)`` for each job, in ``workers`` processes (in this one for 1)."""
    if workers <= 1:
        return [fn(*job) for job in jobs]
    with Pool(workers) as pool:
        return pool.starmap(fn, jobs)


def _states(path: Path, poses: list[str], seeds: range, workers: int) -> dict[str, dict]:
    kept = dict(np.load(path)) if path.is_file() else {}
    states = {}
    jobs = [(p, s) for p in poses for s in seeds
            if f"{p}_{s}_qpos" not in kept and f"{p}_{s}_missing" not in kept]
    for (pose, seed), state in zip(jobs, _starmap(hand_over_state, jobs, workers), strict=True):
        for field, value in (state or {"missing": True}).items():
            kept[f"{pose}_{seed}_{field}"] = np.asarray(value)
    if jobs:
        np.savez(path, **kept)
    for pose in poses:
        for seed in seeds:
            if f"{pose}_{seed}_qpos" in kept:
                states[f"{pose}_{seed}"] = {f: kept[f"{pose}_{seed}_{f}"]
                                            for f in ("qpos", "qvel", "time", "time_scale")}
    return states


def probe(poses: list[str], seeds: range, states_path: Path, rise_time: float = 5.0,
          workers: int = 2, time_scale: float | None = None, servo: str = "qp",
          servo_every: int = 10, range_factor: float = 1.0) -> dict[str, dict]:
    """{pose: {starts, squats, stood, squat_interval, stood_interval}} over the kept states."""
    if servo not in SERVOS:
        raise ValueError(f"unknown servo '{servo}': one of {list(SERVOS)}")
    states = _states(states_path, poses, seeds, workers)
    keys = sorted(states)
    jobs = [(states[k], rise_time, time_scale, servo, servo_every, range_factor)
            for k in keys]
    outcomes = dict(zip(keys, _starmap(replay, jobs, workers), strict=True))
    out = {}
    for pose in poses:
        mine = [o for k, o in outcomes.items() if k.rsplit("_", 1)[0] == pose]
        squats, stood = sum(o != "no_squat" for o in mine), mine.count("stood")
        out[pose] = {"starts": len(mine), "squats": squats, "stood": stood,
                     "squat_interval": wilson_interval(squats, len(mine)),
                     "stood_interval": wilson_interval(stood, len(mine))}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--poses", nargs="+", default=["kneeling", "sitting", "supine"])
    parser.add_argument("--seeds", default="0:20", help="first:end (end excluded)")
    parser.add_argument("--states", type=Path, default=Path("to_squat_states.npz"),
                        help="hand-over states, kept and reused")
    parser.add_argument("--rise", type=float, default=5.0, help="rise time after the squat [s]")
    parser.add_argument("--time-scale", type=float, default=None,
                        help="the move's pace (default: the controller's, kept per state)")
    parser.add_argument("--servo", choices=SERVOS, default="qp",
                        help="what drives the joints during the move (module docstring)")
    parser.add_argument("--servo-every", type=int, default=10,
                        help="physics steps an inverse servo's target is held (10: 50 Hz)")
    parser.add_argument("--range-factor", type=float, default=1.0,
                        help="the robot's joint ranges × this about their middle (0.9: "
                             "the training robot's)")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    first, end = (int(x) for x in args.seeds.split(":"))
    out = probe(args.poses, range(first, end), args.states, args.rise, args.workers,
                args.time_scale, args.servo, args.servo_every, args.range_factor)
    print(f"{'pose':10s} {'starts':>6s} {'squat accepted':>24s} {'stood':>24s}")
    for pose, row in out.items():
        sq, st = row["squat_interval"], row["stood_interval"]
        print(f"{pose:10s} {row['starts']:6d} {row['squats']:5d} [{sq[0]:.2f}, {sq[1]:.2f}]"
              f"{'':9s}{row['stood']:5d} [{st[0]:.2f}, {st[1]:.2f}]")


if __name__ == "__main__":
    main()
