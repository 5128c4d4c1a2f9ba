"""The hand-over map: the learned policy's success from each hand-over state, under noise.

For each state a keyframe (joint targets) and a base orientation: the robot is dropped
onto the floor in that pose with the paper's initialisation noise scaled by ``noise``
(joints ±0.1 rad, base ±0.2 rad, a random heading), settles for ``settle`` seconds under
joint PD holding the keyframe (1× effort limits, targets within 0.9× ranges), then the
shipped policy acts under the capturability supervisor (the ``hybrid`` controller after
its moves). Success is the paper's criterion (§IV). The table, with 95 % Wilson
intervals, decides where the model-based moves hand over.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.supervisor import HybridSupervisor
from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.evaluation.scenario import MAX_NOISE
from hybrid_recovery.evaluation.success import recovery_time, wilson_interval
from hybrid_recovery.getup.keyframes import KEYFRAMES
from hybrid_recovery.observation import projected_gravity
from hybrid_recovery.policy import resolve_policy
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.limits import SafetyLimits
from hybrid_recovery.robot.mjcf import joint_addresses
from hybrid_recovery.sim.divergence import divergence, divergence_after_step
from hybrid_recovery.sim.initial_states import quat_from_euler, quat_mul, seat_single


@dataclass(frozen=True)
class HandoverState:
    """A hand-over state: keyframe name and base orientation (w, x, y, z)."""

    keyframe: str
    base_quat: tuple[float, float, float, float]


HANDOVER_STATES: dict[str, HandoverState] = {
    "knee_chest": HandoverState("knee_chest", (0.522, 0.0, 0.853, 0.0)),
    "hands_knees": HandoverState("hands_knees", (0.796, 0.0, 0.605, 0.0)),
    "kneel_upright": HandoverState("kneel_upright", (1.0, 0.0, 0.0, 0.0)),
    "side_sit": HandoverState("side_sit", (0.865, -0.456, -0.029, 0.209)),
}
"""The states the policy may take over from."""


def handover_start(model: mujoco.MjModel, state: str, rng: np.random.Generator,
                   noise: float = 1.0, settle: float = 1.5) -> mujoco.MjData:
    """A settled, noisy start in hand-over ``state`` on the torque model.

    A settle that diverged stops there; :func:`policy_trial` from it ends as diverged.

    Raises:
        ValueError: an unknown state.
    """
    if state not in HANDOVER_STATES:
        raise ValueError(f"unknown hand-over state '{state}': use one of "
                         f"{sorted(HANDOVER_STATES)}")
    spec = HANDOVER_STATES[state]
    lo, hi = SafetyLimits.from_model(model).q_ref_bounds(0.9)
    qadr, dadr = joint_addresses(model)
    target = np.clip(KEYFRAMES[spec.keyframe] + rng.uniform(-0.1, 0.1, 27) * noise, lo, hi)
    data = mujoco.MjData(model)
    data.qpos[qadr] = target
    rpy = rng.uniform(-0.2, 0.2, 3) * noise
    turn = quat_from_euler(rpy[:1], rpy[1:2], rpy[2:] + rng.uniform(-np.pi, np.pi, 1))
    data.qpos[3:7] = quat_mul(turn, np.array(spec.base_quat)[None])[0]
    data.qpos[3:7] /= np.linalg.norm(data.qpos[3:7])
    seat_single(model, data)
    for _ in range(int(round(settle / model.opt.timestep))):
        data.ctrl[:] = pd_torque(target, data.qpos[qadr], data.qvel[dadr])
        mujoco.mj_step(model, data)
        if divergence(data) is not None:  # kept in data: the trial from it diverged
            break
    data.time = 0.0
    return data


def policy_trial(model: mujoco.MjModel, data: mujoco.MjData, supervisor: HybridSupervisor,
                 duration: float) -> tuple[float | None, str | None]:
    """Runs the supervisor (policy, then QP once up) from ``data``. Stops once it has
    succeeded, or once the simulation has diverged
    (:func:`~hybrid_recovery.sim.divergence.divergence`, the start included).

    Returns:
        (the recovery time [s] by the paper's criterion or None, why and when the
        simulation diverged or None); a diverged trial has no recovery time.
    """
    if (why := divergence(data)) is not None:
        return None, f"{why} before the policy"
    supervisor.reset(model, data)
    torso = model.body(constants.TORSO_BODY).id
    every = max(1, int(round(0.02 / model.opt.timestep)))
    t, h, hd, g = [], [], [], []
    for k in range(int(round(duration / model.opt.timestep))):
        data.ctrl[:] = supervisor(model, data)
        before = data.time
        mujoco.mj_step(model, data)
        if (why := divergence_after_step(model, data, before, k % every == 0)) is not None:
            return None, why
        if k % every == 0:
            mujoco.mj_subtreeVel(model, data)
            t.append(data.time)
            h.append(data.subtree_com[1, 2])
            hd.append(data.subtree_linvel[1, 2])
            g.append(projected_gravity(data.xquat[torso]))
            if len(t) % 25 == 0:
                found = recovery_time(np.array(t), np.array(h), np.array(hd), np.array(g))
                if found is not None:
                    return found, None
    return recovery_time(np.array(t), np.array(h), np.array(hd), np.array(g)), None


def handover_map(states: tuple[str, ...] = tuple(HANDOVER_STATES), trials: int = 20,
                 noise: float = 1.0, duration: float = 15.0, seed: int = 0,
                 policy: str = "shipped") -> list[dict]:
    """The policy's success from each hand-over state.

    Args:
        states: hand-over states, names of :data:`HANDOVER_STATES`.
        trials: trials per state, >= 1.
        noise: scale of the initialisation noise, finite, in [0, ``MAX_NOISE``].
        duration: trial length [s], finite, > 0.
        seed: >= 0.
        policy: ``policy.onnx``, its directory, or ``shipped``.

    Returns:
        One row per state: ``state``, ``trials``, ``successes``, ``rate``, ``ci`` (95 %
        Wilson interval), ``mean_time`` [s] of the successes (None without any),
        ``diverged`` (trials whose simulation diverged: failures, never successes).

    Raises:
        ValueError: an unknown state, or a number out of its range (named, with its
            value).
    """
    if trials < 1:
        raise ValueError(f"trials must be >= 1, got {trials}")
    if not (np.isfinite(noise) and 0.0 <= noise <= MAX_NOISE):
        raise ValueError(f"noise must be a finite number from 0 to {MAX_NOISE:g}, "
                         f"got {noise}")
    if not (np.isfinite(duration) and duration > 0.0):
        raise ValueError(f"duration must be a finite number > 0, got {duration}")
    if seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed}")
    for k, state in enumerate(states):
        if state not in HANDOVER_STATES:
            raise ValueError(f"unknown hand-over state '{state}': use one of "
                             f"{sorted(HANDOVER_STATES)}")
        if state in states[:k]:
            raise ValueError(f"hand-over state '{state}' is named twice")
    path = resolve_policy(policy)
    supervisor = HybridSupervisor.from_onnx(path / "policy.onnx" if path.is_dir() else path)
    model = load_torque_model()
    rows = []
    for k, state in enumerate(states):
        rng = np.random.default_rng([seed, k])
        times, diverged = [], 0
        for _ in range(trials):
            data = handover_start(model, state, rng, noise)
            found, why = policy_trial(model, data, supervisor, duration)
            diverged += why is not None
            if found is not None:
                times.append(found)
        lo, hi = wilson_interval(len(times), trials)
        rows.append({"state": state, "trials": trials, "successes": len(times),
                     "rate": len(times) / trials, "ci": (lo, hi),
                     "mean_time": float(np.mean(times)) if times else None,
                     "diverged": diverged})
    return rows


def map_table(rows: list[dict]) -> str:
    """Markdown table of :func:`handover_map` rows."""
    lines = ["| hand-over state | trials | success | 95 % CI | mean time to stand [s] | "
             "diverged |", "|---|---|---|---|---|---|"]
    for r in rows:
        t = "–" if r["mean_time"] is None else f"{r['mean_time']:.1f}"
        lines.append(f"| {r['state']} | {r['trials']} | {100 * r['rate']:.0f} % | "
                     f"{100 * r['ci'][0]:.0f}–{100 * r['ci'][1]:.0f} % | {t} | "
                     f"{r.get('diverged', 0)} |")
    return "\n".join(lines)
