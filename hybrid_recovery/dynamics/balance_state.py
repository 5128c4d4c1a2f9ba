"""The balance state of a floating-base robot: CoM, momentum and capture point."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BalanceState:
    """Centroidal balance quantities, world axes; leading shape ``()`` or ``(N,)``.

    Attributes:
        com: CoM position p_c, shape (..., 3) [m].
        com_vel: CoM velocity ṗ_c, shape (..., 3) [m/s].
        com_acc: CoM acceleration p̈_c, shape (..., 3) [m/s²], or None if no qacc was given.
        linear_momentum: p_l = m ṗ_c, shape (..., 3) [kg·m/s].
        angular_momentum: L about the CoM, shape (..., 3) [kg·m²/s].
        capture_point: ξ = p_c,xy + ṗ_c,xy / ω, shape (..., 2) [m].
        omega: ω = √(g / h_c), h_c the CoM height above the ground, shape (...) [1/s].
        mass: total mass m [kg].
    """

    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray | None
    linear_momentum: np.ndarray
    angular_momentum: np.ndarray
    capture_point: np.ndarray
    omega: np.ndarray
    mass: float
