"""``bench dynamics``: the Pinocchio balance quantities against MuJoCo, µs per state.

Timed over N random states of the project's H1-2 (no floor, no actuators):

* ``balance_state``: :meth:`RobotModel.balance_state`, one batched call (N, nq);
* ``centroidal_momentum_matrix``: A(q), one batched call;
* ``centroidal_momentum_drift``: Ȧ q̇, one batched call;
* ``mj_forward+subtreeVel``: MuJoCo's ``mj_forward`` then ``mj_subtreeVel`` per state,
  one MjData in a Python loop, the figure the issue compares against;
* ``mj_kinematics..subtreeVel``: the least MuJoCo needs for the same CoM and momenta
  (``mj_kinematics``, ``mj_comPos``, ``mj_comVel``, ``mj_subtreeVel``), to show how much
  of ``mj_forward`` is collision, actuation and constraint work the balance quantities
  do not need.

Ratios are time / time of ``mj_forward+subtreeVel`` (< 1: faster than MuJoCo). The run
also checks that both sides compute the same thing: the largest error of the CoM, linear
and angular momentum of ``balance_state`` against MuJoCo's subtree quantities, relative
to their largest magnitude.
"""

from __future__ import annotations

import os

import numpy as np

from hybrid_recovery.bench.result import BenchResult
from hybrid_recovery.bench.timing import best_seconds

MJ_FORWARD = "mj_forward+subtreeVel"
MJ_MINIMAL = "mj_kinematics..subtreeVel"


def random_states(mj_model, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """N random states: base pose ~ N(0, 1) m and a uniform unit quaternion, joints
    uniform in their ranges (±π where unlimited), qvel ~ N(0, 1).

    Returns:
        qpos (N, nq) and qvel (N, nv), MuJoCo conventions.
    """
    qpos = np.zeros((n, mj_model.nq))
    qpos[:, :3] = rng.normal(size=(n, 3))
    quat = rng.normal(size=(n, 4))
    qpos[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    limited = mj_model.jnt_limited[1:].astype(bool)
    low = np.where(limited, mj_model.jnt_range[1:, 0], -np.pi)
    high = np.where(limited, mj_model.jnt_range[1:, 1], np.pi)
    qpos[:, 7:] = rng.uniform(low, high, size=(n, len(low)))
    return qpos, rng.normal(size=(n, mj_model.nv))


def run_dynamics_bench(n: int = 1024, repeat: int = 3, seed: int = 0) -> BenchResult:
    """Times the balance quantities and MuJoCo's on ``n`` random states.

    Args:
        n: Number of random states N ≥ 1.
        repeat: Timed runs per quantity ≥ 1; the best is kept.
        seed: Seed of the random states.

    Returns:
        Table rows (quantity, µs per state, ratio to ``mj_forward+subtreeVel``) and
        figures ``n``, ``repeat``, ``us_per_state``, ``ratio_to_mj_forward``,
        ``max_rel_error_vs_mujoco``, ``cpu_count``, ``loadavg_1min``.

    Raises:
        ValueError: When n < 1 or repeat < 1.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}")
    # Heavy imports here, not at the top: the CLI imports every bench module to list them.
    import mujoco

    from hybrid_recovery.dynamics import RobotModel

    robot = RobotModel.h1_2()
    model, data = robot.mj_model, mujoco.MjData(robot.mj_model)
    qpos, qvel = random_states(model, n, np.random.default_rng(seed))

    def mj_forward() -> None:
        for i in range(n):
            data.qpos[:], data.qvel[:] = qpos[i], qvel[i]
            mujoco.mj_forward(model, data)
            mujoco.mj_subtreeVel(model, data)

    def mj_minimal() -> None:
        for i in range(n):
            data.qpos[:], data.qvel[:] = qpos[i], qvel[i]
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            mujoco.mj_comVel(model, data)
            mujoco.mj_subtreeVel(model, data)

    timed = {
        "balance_state": lambda: robot.balance_state(qpos, qvel),
        "centroidal_momentum_matrix": lambda: robot.centroidal_momentum_matrix(qpos),
        "centroidal_momentum_drift": lambda: robot.centroidal_momentum_drift(qpos, qvel),
        MJ_FORWARD: mj_forward,
        MJ_MINIMAL: mj_minimal,
    }
    us = {name: best_seconds(fn, repeat) / n * 1e6 for name, fn in timed.items()}
    ratio = {name: t / us[MJ_FORWARD] for name, t in us.items()}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return BenchResult(
        name="dynamics",
        title=f"bench dynamics: N = {n} random H1-2 states, best of {repeat}, "
              f"{os.cpu_count()} CPUs, load average {load:.2f}; "
              f"ratio = time / time of {MJ_FORWARD}",
        columns=("quantity", "us/state", "ratio"),
        rows=[(name, us[name], ratio[name]) for name in timed],
        figures={
            "n": n,
            "repeat": repeat,
            "us_per_state": us,
            "ratio_to_mj_forward": ratio,
            "max_rel_error_vs_mujoco": _max_rel_error(robot, model, data, qpos, qvel),
            "cpu_count": os.cpu_count(),
            "loadavg_1min": load,
        },
    )


def _max_rel_error(robot, model, data, qpos: np.ndarray, qvel: np.ndarray) -> float:
    """max |x − x_MuJoCo| / max |x_MuJoCo| over the CoM, p_l and L of all states."""
    import mujoco

    root = int(model.jnt_bodyid[0])
    ref = np.empty((len(qpos), 9))
    for i in range(len(qpos)):
        data.qpos[:], data.qvel[:] = qpos[i], qvel[i]
        mujoco.mj_forward(model, data)
        mujoco.mj_subtreeVel(model, data)
        ref[i] = np.r_[data.subtree_com[root], model.body_subtreemass[root]
                       * data.subtree_linvel[root], data.subtree_angmom[root]]
    state = robot.balance_state(qpos, qvel)
    got = np.c_[state.com, state.linear_momentum, state.angular_momentum]
    return max(float(np.abs(got[:, k:k + 3] - ref[:, k:k + 3]).max()
                     / np.abs(ref[:, k:k + 3]).max()) for k in (0, 3, 6))
