"""A balance report: the dynamics layer on the standing H1-2 and during a torso push."""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.dynamics.capturability import zero_step_margin
from hybrid_recovery.dynamics.support import support_polygon
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import default_qpos, load_mjmodel
from hybrid_recovery.sim.divergence import SimulationDiverged, divergence

_FOOT_CORNERS = [f"{side}_foot_{c}" for side in ("left", "right") for c in ("fl", "fr", "rl", "rr")]


def balance_report(push_force: float = 150.0, push_duration: float = 0.1,
                   duration: float = 2.0) -> list[dict]:
    """Simulates the robot standing under its PD, pushed forward at the torso at t = 0.5 s.

    Args:
        push_force: |F| [N], along +x at the torso CoM.
        push_duration: [s].
        duration: simulated time [s].

    Returns:
        One row every 0.1 s: time [s], CoM height [m], capture point ξ [m], its 0-step
        margin to the feet polygon [m] (positive inside), |L| [kg·m²/s].

    Raises:
        SimulationDiverged: the push made the simulation diverge
            (:func:`~hybrid_recovery.sim.divergence.divergence`).
    """
    model = load_mjmodel()
    data = mujoco.MjData(model)
    data.qpos[:] = default_qpos(model)
    data.ctrl[:] = constants.DEFAULT_JOINT_POS
    robot = RobotModel(model)
    torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, constants.TORSO_BODY)
    corners = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, n) for n in _FOOT_CORNERS]
    rows, dt = [], model.opt.timestep
    every = int(round(0.1 / dt))
    for step in range(int(round(duration / dt)) + 1):
        t = step * dt
        data.xfrc_applied[torso, 0] = push_force if 0.5 <= t < 0.5 + push_duration else 0.0
        mujoco.mj_forward(model, data)
        if step % every == 0:
            state = robot.balance_state(data.qpos, data.qvel)
            feet = support_polygon(data.site_xpos[corners])
            rows.append({"t": t, "com_height": float(state.com[2]),
                         "capture_point": state.capture_point.round(4).tolist(),
                         "margin": float(zero_step_margin(state.capture_point, feet)),
                         "angular_momentum": float(np.linalg.norm(state.angular_momentum))})
        mujoco.mj_step(model, data)
        if (why := divergence(data)) is not None:
            raise SimulationDiverged(f"the simulation diverged at t = {t + dt:.3f} s ({why}) "
                                     f"under the {push_force:g} N push")
    return rows


def print_report(rows: list[dict], push_force: float) -> None:
    print(f"H1-2 standing under PD, {push_force:.0f} N forward torso push at t = 0.5 s")
    print(f"{'t [s]':>6} {'h_c [m]':>8} {'xi_x [m]':>9} {'xi_y [m]':>9} "
          f"{'margin [m]':>11} {'|L| [kg m2/s]':>14}")
    for r in rows:
        x, y = r["capture_point"]
        print(f"{r['t']:6.2f} {r['com_height']:8.3f} {x:9.3f} {y:9.3f} {r['margin']:11.3f} "
              f"{r['angular_momentum']:14.3f}")
