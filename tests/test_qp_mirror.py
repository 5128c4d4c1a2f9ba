"""Left and right pushes on the QP start from mirror-image states and end mirrored.

The robot is left–right symmetric; so is the QP controller. A push cell to the right
starts from the mirror image of its leftward twin's start state, so that the two differ
only in the side pushed (all cells once started from one leaning state, and the QP held
pushes to one side better than to the other).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.controllers import make
from hybrid_recovery.evaluation.scenario import SWEEP_DIRECTIONS, Scenario
from hybrid_recovery.evaluation.trial import run_trial, start_state
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import load_mjmodel
from hybrid_recovery.sim.initial_states import mirror_qpos


def _push(direction: str, force: float = 300.0, seed: int = 3) -> Scenario:
    return Scenario("standing", force, SWEEP_DIRECTIONS[direction], 0.2, duration=2.5,
                    seed=seed, noise=0.25)


def test_mirror_qpos_mirrors_the_centre_of_mass_and_is_an_involution():
    model = load_mjmodel()
    qadr = model.jnt_qposadr[1:1 + constants.NUM_JOINTS]
    qpos = start_state(_push("front"), None, "default")
    data = mujoco.MjData(model)
    coms = []
    for q in (qpos, mirror_qpos(qpos, qadr)):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        coms.append(data.subtree_com[1].copy())
    np.testing.assert_allclose(coms[1], coms[0] * [1.0, -1.0, 1.0], atol=2e-3)
    np.testing.assert_allclose(mirror_qpos(mirror_qpos(qpos, qadr), qadr), qpos, atol=1e-15)


def test_right_pushes_start_from_the_mirrored_left_start():
    model = load_mjmodel()
    qadr = model.jnt_qposadr[1:1 + constants.NUM_JOINTS]
    left, right = (start_state(_push(d), None, "default") for d in ("left", "right"))
    np.testing.assert_array_equal(right, mirror_qpos(left, qadr))
    front, back = (start_state(_push(d), None, "default") for d in ("front", "back"))
    np.testing.assert_array_equal(front, back)  # front/back: the unmirrored state
    np.testing.assert_array_equal(front, left)


@pytest.mark.slow
@pytest.mark.parametrize(("force", "held"), [(300.0, True), (450.0, False)])
def test_mirrored_pushes_give_mirrored_outcomes(force, held):
    """Held at 300 N and lost at 450 N on both sides; the CoM paths mirror within 1 cm
    (throughout when held; until the steps, 0.4 s after the push, when lost: stepping
    and falling amplify the solver's round-off)."""
    qp = make("qp")
    left, right = (run_trial(qp, _push(d, force), record=True) for d in ("left", "right"))
    assert left["success"] == right["success"] == held
    assert left["fell"] == right["fell"] == (not held)
    t = left["trace"]["t"]
    n = len(t) if held else int(np.searchsorted(t, _push("left").push_time + 0.4))
    com_l, com_r = left["trace"]["com"][:n], right["trace"]["com"][:n]
    np.testing.assert_allclose(com_r[:, 1], -com_l[:, 1], atol=0.01)
    np.testing.assert_allclose(com_r[:, 2], com_l[:, 2], atol=0.01)
