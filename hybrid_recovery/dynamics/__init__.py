"""Balance dynamics: Pinocchio centroidal quantities, support geometry and capturability."""

from hybrid_recovery.dynamics.balance_state import BalanceState
from hybrid_recovery.dynamics.centroidal import net_centroidal_wrench
from hybrid_recovery.dynamics.robot_model import GRAVITY, RobotModel

__all__ = ["GRAVITY", "BalanceState", "RobotModel", "net_centroidal_wrench"]
