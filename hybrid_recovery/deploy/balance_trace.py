"""A balance trace over time: CoM height, capture point and torso tilt, as CSV and a plot."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.files import atomic_path, atomic_write

COLUMNS = ("t", "phase", "com_x", "com_y", "com_z", "com_vx", "com_vy", "com_vz", "cp_x",
           "cp_y", "pelvis_z", "tilt_deg", "push")
"""CSV columns: time [s], safety phase, CoM [m], CoM velocity [m/s], capture point
ξ = c + ċ/ω [m], pelvis height [m], torso tilt from vertical [deg], push force [N]."""


@dataclass
class BalanceTrace:
    """Rows of balance quantities, one per control step.

    Args:
        robot_model: Pinocchio model of the simulated robot (ground at z = 0).
    """

    robot_model: RobotModel
    rows: list[tuple] = field(default_factory=list)

    def record(self, t: float, phase: str, qpos: np.ndarray, qvel: np.ndarray,
               gravity_b: np.ndarray, push: float) -> None:
        """Appends one row; ``gravity_b`` is the torso IMU's projected gravity (3,)."""
        bs = self.robot_model.balance_state(qpos, qvel)
        tilt = float(np.degrees(np.arccos(np.clip(-gravity_b[2], -1.0, 1.0))))
        self.rows.append((t, phase, *bs.com, *bs.com_vel, *bs.capture_point, float(qpos[2]),
                          tilt, push))

    def column(self, name: str) -> np.ndarray:
        """One column as an array (floats; ``phase`` as strings)."""
        i = COLUMNS.index(name)
        values = [r[i] for r in self.rows]
        return np.array(values) if name == "phase" else np.array(values, dtype=float)

    def write_csv(self, path: str | Path) -> Path:
        """The rows as CSV with a header of :data:`COLUMNS`, written atomically."""
        path = Path(path)

        def write(f) -> None:
            writer = csv.writer(f)
            writer.writerow(COLUMNS)
            for row in self.rows:
                writer.writerow([row[0], row[1], *(f"{v:.6g}" for v in row[2:])])

        atomic_write(path, "w", write)
        return path

    def plot(self, path: str | Path, title: str = "") -> Path:
        """CoM height, capture point and CoM (x, y), and torso tilt over time, as a PNG."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        t = self.column("t")
        push = self.column("push") > 0
        fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
        axes[0].plot(t, self.column("com_z"), label="CoM height h_c")
        axes[0].plot(t, self.column("pelvis_z"), "--", label="pelvis height")
        axes[0].set_ylabel("m")
        for name, style in (("cp_x", "-"), ("cp_y", "-"), ("com_x", ":"), ("com_y", ":")):
            axes[1].plot(t, self.column(name), style, label=name.replace("cp", "ξ"))
        axes[1].set_ylabel("m (world)")
        axes[2].plot(t, self.column("tilt_deg"), label="torso tilt")
        axes[2].set_ylabel("deg")
        axes[2].set_xlabel("time [s]")
        for ax in axes:
            if push.any():
                ax.fill_between(t, 0, 1, where=push, transform=ax.get_xaxis_transform(),
                                color="tab:red", alpha=0.15, label="push")
            ax.legend(loc="best", fontsize=8)
            ax.grid(alpha=0.3)
        axes[0].set_title(title)
        fig.tight_layout()
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=100)
        plt.close(fig)
        return Path(path)
