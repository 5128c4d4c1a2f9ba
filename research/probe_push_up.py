"""Probe: the push-up from knee-chest to hands and knees, torque QP against joint PD.

From the hand-over map's noisy settled knee-chest (``handover_start``: the keyframe with
the paper's initialisation noise, dropped and held 1.5 s under joint PD) each trial runs
the move ``duration`` + ``hold`` seconds at 2 ms on the torque model (``ctrl = τ``), either

* ``qp``: :class:`hybrid_recovery.getup.push_up.PushUp` (the multi-contact torque QP on
  hands, knees and toes), or
* ``pd``: joint PD at the deployment gains on the same smoothstep from the start joints
  to the hands-and-knees keyframe (ranges × 0.9), clipped at 1× effort,

and reports whether it ends on hands and knees (``on_hands_and_knees``), the worst
torque ratio max_j |τ_j|/τ_max,j along it (for PD the unclipped demand, so > 1 means
saturated), the share of steps with some joint at its limit, and the QP's statuses.

    python research/probe_push_up.py --seeds 0 1 2 3 4 5 6 7 8 9
"""

from __future__ import annotations

import argparse

import mujoco
import numpy as np

from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.evaluation.handover_map import handover_start
from hybrid_recovery.evaluation.success import wilson_interval
from hybrid_recovery.getup.keyframes import KEYFRAMES
from hybrid_recovery.getup.push_up import PushUp, PushUpConfig, on_hands_and_knees
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses


def _trial(model: mujoco.MjModel, seed: int, controller: str, duration: float,
           hold: float) -> dict:
    data = handover_start(model, "knee_chest", np.random.default_rng(seed))
    qadr, dadr = joint_addresses(model)
    lo, hi = SafetyLimits.from_model(model).q_ref_bounds(0.9)
    q0, q1 = data.qpos[qadr].copy(), np.clip(KEYFRAMES["hands_knees"], lo, hi)
    push_up = PushUp(PushUpConfig(duration=duration))
    push_up.reset(model, data)
    worst, saturated = 0.0, 0
    steps = int(round((duration + hold) / model.opt.timestep))
    for _ in range(steps):
        if controller == "qp":
            tau = push_up(model, data)
        else:
            t = min(float(data.time) / duration, 1.0)
            q_ref = q0 + t * t * (3.0 - 2.0 * t) * (q1 - q0)
            tau = constants.KP * (q_ref - data.qpos[qadr]) - constants.KD * data.qvel[dadr]
        ratio = np.abs(tau) / constants.EFFORT_LIMITS
        worst = max(worst, float(ratio.max()))
        saturated += bool(np.any(ratio >= 0.999))
        data.ctrl[:] = np.clip(tau, -constants.EFFORT_LIMITS, constants.EFFORT_LIMITS)
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    arrived, what = on_hands_and_knees(model, data)
    statuses = push_up.statuses if controller == "qp" else {}
    return {"arrived": arrived, "what": what, "worst": worst,
            "saturated": saturated / steps, "statuses": statuses}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    parser.add_argument("--controllers", nargs="+", choices=("qp", "pd"), default=["qp", "pd"])
    parser.add_argument("--duration", type=float, default=3.0, help="smoothstep [s]")
    parser.add_argument("--hold", type=float, default=1.5, help="after the smoothstep [s]")
    args = parser.parse_args()
    model = load_torque_model()
    for controller in args.controllers:
        results = []
        for seed in args.seeds:
            r = _trial(model, seed, controller, args.duration, args.hold)
            results.append(r)
            print(f"{controller} seed {seed}: {'arrived' if r['arrived'] else 'missed'}, "
                  f"worst torque ratio {r['worst']:.2f}, at a limit {r['saturated']:.1%} "
                  f"of steps {r['statuses']} | {r['what']}", flush=True)
        n = sum(r["arrived"] for r in results)
        lo, hi = wilson_interval(n, len(results))
        print(f"{controller}: {n}/{len(results)} on hands and knees (95 % CI {lo:.0%}–{hi:.0%})")


if __name__ == "__main__":
    main()
