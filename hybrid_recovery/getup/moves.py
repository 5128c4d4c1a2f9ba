"""Contact-state moves on the ground: sequences of joint keyframes between ground states.

A move goes from one ground state (:mod:`hybrid_recovery.getup.ground_state`) to another
through phases; each phase interpolates the PD targets from the joints measured at its
start to a keyframe (a smoothstep over ``duration``), then holds them for ``hold``.
Executed under joint PD at the deployment gains and 1× effort limits, targets within the
joint ranges × 0.9. Whether a move arrived is checked on the state it ends in.

* ``lie_back``: sitting → supine (the torso lowered onto the back);
* ``roll``: supine → prone, a dynamic roll over the left side (waist twist, arm swing,
  tucked legs); no statically balanced roll exists, the torso falls onto its side;
* ``to_front``: lying on a side → prone;
* ``tuck``: prone → knee-chest, knees drawn under the hips in 5 s.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Phase:
    """Targets move to ``keyframe`` over ``duration`` [s], then stay for ``hold`` [s].

    ``dynamic``: the phase is not meant to be statically balanced (the roll's fall onto
    its side); the static check along the move reports it as such.
    """

    keyframe: str
    duration: float
    hold: float
    dynamic: bool = False


@dataclass(frozen=True)
class Move:
    """A named move from ground state ``start`` to ground state ``end``."""

    name: str
    start: str
    end: str
    phases: tuple[Phase, ...]


MOVES: dict[str, Move] = {m.name: m for m in (
    Move("lie_back", "sitting", "supine", (Phase("supine_rest", 1.5, 1.0),)),
    Move("roll", "supine", "prone", (Phase("tuck", 1.0, 0.2),
                                     Phase("roll_twist", 0.8, 0.5, dynamic=True),
                                     Phase("roll_unwind", 0.8, 0.5, dynamic=True),
                                     Phase("prone_hands", 1.0, 1.0))),
    Move("to_front", "side", "prone", (Phase("prone_hands", 1.0, 1.0),)),
    Move("tuck", "prone", "knee_chest", (Phase("knee_chest", 5.0, 1.0),)),
)}
"""The executor's moves by name."""

NEXT_MOVE: dict[str, str] = {m.start: m.name for m in MOVES.values()}
"""The move that leads on from each ground state towards knee-chest."""

ALL_MOVES: dict[str, Move] = dict(MOVES)
"""Every move by name: the executor's and those it does not plan (run one with
:class:`hybrid_recovery.getup.single_move.SingleMove`)."""
