"""One named move executed from whatever state the robot is in, then classified.

:class:`SingleMove` is :class:`hybrid_recovery.getup.move_executor.GroundMoves` with its
planning replaced: after the settle time it starts the named move (any move of
:data:`ALL_MOVES`, also one the executor's plan does not use), runs its phases exactly as
the executor does (the same interpolation, PD law and ranges), and when the last phase
ends it stops, ``arrived`` if the robot is in the move's end state, else ``stuck``.
"""

from __future__ import annotations

import mujoco

from hybrid_recovery.control.diagnostics import Event
from hybrid_recovery.getup.ground_state import classify, read_ground_pose
from hybrid_recovery.getup.move_executor import ARRIVED, MOVING, STUCK, GroundMoves, MoveConfig
from hybrid_recovery.getup.moves import ALL_MOVES


class SingleMove(GroundMoves):
    """Executes move ``name`` once.

    Args:
        name: A move of :data:`ALL_MOVES`.
        config: Settings (ranges, settle time); defaults when None.
        mirrored: Run the move mirrored (left ↔ right).

    Attributes:
        start_state: The ground state the move started from.

    Raises:
        ValueError: an unknown move.
    """

    def __init__(self, name: str, config: MoveConfig | None = None,
                 mirrored: bool = False) -> None:
        if name not in ALL_MOVES:
            raise ValueError(f"unknown move '{name}': use one of {sorted(ALL_MOVES)}")
        super().__init__(config)
        self.name, self._mirror = name, mirrored
        self.start_state = ""

    def _plan(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        t = float(data.time)
        self.state = classify(read_ground_pose(model, data))
        if self.moves_tried == 0:
            self.moves_tried, self.start_state = 1, self.state
            self.move, self.mirrored, self.status = ALL_MOVES[self.name], self._mirror, MOVING
            self.events.append(Event(t, "move", f"{self.name} from {self.state}"
                                     + (" (mirrored)" if self.mirrored else "")))
            self._start_phase(0, data)
            return
        end = ALL_MOVES[self.name].end
        self.move = None
        self.status = ARRIVED if self.state == end else STUCK
        self.events.append(Event(t, "arrived" if self.status == ARRIVED else "stuck",
                                 f"in {self.state}"))
