"""RobotModel: Pinocchio balance dynamics with MuJoCo-convention inputs."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from hybrid_recovery.dynamics.balance_state import BalanceState
from hybrid_recovery.dynamics.capturability import capture_point
from hybrid_recovery.dynamics.conventions import (
    qacc_to_pin,
    qpos_to_pin,
    quat_wxyz_to_matrix,
    qvel_to_pin,
)
from hybrid_recovery.dynamics.pinocchio_model import build_pinocchio_model

GRAVITY = 9.81
"""Gravitational acceleration g [m/s²]."""


class RobotModel:
    """Exact centroidal dynamics of a floating-base robot (Pinocchio).

    Inputs are MuJoCo's ``qpos``, ``qvel``, ``qacc`` exactly as MuJoCo stores them, one
    state ``(nq,)`` or a batch ``(N, nq)``. Outputs are in world axes; angular momentum is
    about the CoM.

    Args:
        mj_model: Compiled MuJoCo model of the robot (free joint at the root).
        ground_height: Height of the ground plane z_g [m], for h_c = p_c,z − z_g.
    """

    def __init__(self, mj_model: mujoco.MjModel, ground_height: float = 0.0) -> None:
        self.mj_model = mj_model
        self.model = build_pinocchio_model(mj_model)
        self.data = self.model.createData()
        self.mass = float(pin.computeTotalMass(self.model))
        self.nq, self.nv = self.model.nq, self.model.nv
        self.ground_height = float(ground_height)

    @classmethod
    def h1_2(cls) -> RobotModel:
        """The project's own H1-2 model (``models/h1_2/h1_2.xml``)."""
        from hybrid_recovery.robot.mjcf import load_mjmodel

        return cls(load_mjmodel(floor=False, actuators=False))

    @classmethod
    def from_mjcf(cls, path: str | Path) -> RobotModel:
        """Loads any MJCF with a free joint at its root (e.g. the reference H1-2 file).

        Raises:
            FileNotFoundError: if ``path`` does not exist.
            ValueError: if the model cannot be parsed or has no free joint.
        """
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"MJCF file not found: {path}")
        try:
            mj_model = mujoco.MjModel.from_xml_path(str(path))
        except ValueError as err:
            raise ValueError(f"cannot parse MJCF {path}: {err}") from err
        return cls(mj_model)

    # ------------------------------------------------------------------ validation
    def _check(self, name: str, value: np.ndarray, width: int) -> np.ndarray:
        arr = np.asarray(value, dtype=float)
        if arr.ndim not in (1, 2) or arr.shape[-1] != width:
            raise ValueError(f"{name} must have shape ({width},) or (N, {width}), got {arr.shape}")
        bad = ~np.isfinite(arr).reshape(-1, width).all(axis=1)
        if bad.any():
            raise ValueError(f"{name} contains NaN or inf (rows {np.flatnonzero(bad).tolist()})")
        return arr

    def _states(self, qpos, qvel=None, qacc=None):
        qpos = self._normalised(self._check("qpos", qpos, self.nq))
        out = [qpos]
        for name, arr in (("qvel", qvel), ("qacc", qacc)):
            if arr is not None:
                arr = self._check(name, arr, self.nv)
                if arr.shape[:-1] != qpos.shape[:-1]:
                    raise ValueError(f"{name} batch shape {arr.shape[:-1]} does not match "
                                     f"qpos batch shape {qpos.shape[:-1]}")
            out.append(arr)
        return out

    @staticmethod
    def _normalised(qpos: np.ndarray) -> np.ndarray:
        """qpos with the base quaternion qpos[3:7] scaled to unit norm, as MuJoCo reads
        it (``mj_kinematics`` normalises every free-joint quaternion); a zero one has no
        orientation and is refused."""
        quat = qpos[..., 3:7]
        norm = np.linalg.norm(quat, axis=-1, keepdims=True)
        zero = (norm < 1e-10).reshape(-1)
        if zero.any():
            raise ValueError(f"qpos base quaternion qpos[3:7] is zero "
                             f"(rows {np.flatnonzero(zero).tolist()})")
        out = qpos.copy()
        out[..., 3:7] = quat / norm
        return out

    # ------------------------------------------------------------------ quantities
    def balance_state(
        self, qpos: np.ndarray, qvel: np.ndarray, qacc: np.ndarray | None = None
    ) -> BalanceState:
        """CoM state, whole-body momentum and capture point.

        Args:
            qpos: MuJoCo positions, shape (nq,) or (N, nq).
            qvel: MuJoCo velocities, shape (nv,) or (N, nv).
            qacc: MuJoCo accelerations (optional), same shape as qvel.

        Returns:
            BalanceState with leading shape () or (N,).
        """
        qpos, qvel, qacc = self._states(qpos, qvel, qacc)
        single = qpos.ndim == 1
        qpos2, qvel2 = np.atleast_2d(qpos), np.atleast_2d(qvel)
        q, v = qpos_to_pin(qpos2), qvel_to_pin(qpos2, qvel2)
        a = None if qacc is None else qacc_to_pin(qpos2, qvel2, np.atleast_2d(qacc))
        n = q.shape[0]
        com, lin, ang = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
        acc = None if a is None else np.empty((n, 3))
        model, data = self.model, self.data
        for i in range(n):
            if a is None:
                hg = pin.computeCentroidalMomentum(model, data, q[i], v[i])
            else:
                assert acc is not None
                dhg = pin.computeCentroidalMomentumTimeVariation(model, data, q[i], v[i], a[i])
                acc[i] = dhg.linear / self.mass
                hg = data.hg
            com[i] = data.com[0]
            lin[i] = hg.linear
            ang[i] = hg.angular
        vel = lin / self.mass
        height = com[:, 2] - self.ground_height
        omega = np.sqrt(GRAVITY / np.maximum(height, 1e-3))
        cp = capture_point(com[:, :2], vel[:, :2], np.maximum(height, 1e-3), g=GRAVITY)
        pick = (lambda x: x[0]) if single else (lambda x: x)
        return BalanceState(
            com=pick(com), com_vel=pick(vel), com_acc=None if acc is None else pick(acc),
            linear_momentum=pick(lin), angular_momentum=pick(ang), capture_point=pick(cp),
            omega=pick(omega), mass=self.mass,
        )

    def centroidal_momentum_matrix(self, qpos: np.ndarray) -> np.ndarray:
        """Centroidal momentum matrix A with ``A @ qvel = [p_l; L]`` for MuJoCo's qvel.

        A = A_G(q) T(q), A_G Pinocchio's CMM (world axes, about the CoM) and
        T = block-diag(Rᵀ, I₃, I) the map from MuJoCo's qvel to Pinocchio's v.

        Args:
            qpos: shape (nq,) or (N, nq).

        Returns:
            A, shape (6, nv) or (N, 6, nv).
        """
        (qpos,) = self._states(qpos)[:1]
        qpos2 = np.atleast_2d(qpos)
        q = qpos_to_pin(qpos2)
        rot = quat_wxyz_to_matrix(qpos2[:, 3:7])
        out = np.empty((q.shape[0], 6, self.nv))
        zero = np.zeros(self.nv)
        for i in range(q.shape[0]):
            out[i] = pin.ccrba(self.model, self.data, q[i], zero)
            out[i][:, 0:3] = out[i][:, 0:3] @ rot[i].T
        return out[0] if qpos.ndim == 1 else out

    def centroidal_momentum_drift(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """Bias term Ȧ qvel of ḣ = A qacc + Ȧ qvel (MuJoCo coordinates), world axes.

        Args:
            qpos: shape (nq,) or (N, nq).
            qvel: shape (nv,) or (N, nv).

        Returns:
            Ȧ qvel = [ṗ_l; L̇] at qacc = 0, shape (6,) or (N, 6) [N, N·m].
        """
        qpos, qvel = self._states(qpos, qvel)[:2]
        qpos2, qvel2 = np.atleast_2d(qpos), np.atleast_2d(qvel)
        q, v = qpos_to_pin(qpos2), qvel_to_pin(qpos2, qvel2)
        a = qacc_to_pin(qpos2, qvel2, np.zeros_like(qvel2))
        out = np.empty((q.shape[0], 6))
        for i in range(q.shape[0]):
            out[i] = pin.computeCentroidalMomentumTimeVariation(
                self.model, self.data, q[i], v[i], a[i]
            ).vector
        return out[0] if qpos.ndim == 1 else out
