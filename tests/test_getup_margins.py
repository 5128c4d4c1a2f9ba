"""The static check along the moves: contacts read from MuJoCo, margins of held keyframes,
an unsupported hand-made state, the table, the CLI and its messages."""

from __future__ import annotations

import csv

import mujoco
import numpy as np
import pytest

from hybrid_recovery.cli.main import main
from hybrid_recovery.control.policy_controller import pd_torque
from hybrid_recovery.control.torque_model import load_torque_model
from hybrid_recovery.dynamics import RobotModel
from hybrid_recovery.dynamics.robot_model import GRAVITY
from hybrid_recovery.evaluation.move_margins import margin_table, move_margins, move_start
from hybrid_recovery.getup.contact_ik import CONTACT_KEYFRAMES, ContactIk
from hybrid_recovery.getup.contact_map import GEOM_CONTACTS, floor_contacts
from hybrid_recovery.getup.feasibility import static_feasibility
from hybrid_recovery.getup.margins import margins_along, state_margin, summarise
from hybrid_recovery.getup.moves import ALL_MOVES
from hybrid_recovery.getup.single_move import SingleMove
from hybrid_recovery.robot import constants
from hybrid_recovery.sim.initial_states import seat_single

UNKNOWN_MOVE = f"unknown move 'fly': use one of {sorted(ALL_MOVES)}"


@pytest.fixture(scope="module")
def model():
    return load_torque_model()


@pytest.fixture(scope="module")
def robot(model):
    return RobotModel(model)


@pytest.fixture(scope="module")
def ik(model):
    return ContactIk(model)


def test_every_collision_geom_is_a_named_contact(model):
    for g in range(model.ngeom):
        if model.geom_bodyid[g] > 0 and model.geom_contype[g]:
            assert model.geom(g).name in GEOM_CONTACTS, model.geom(g).name


@pytest.mark.parametrize("lean, expected", [
    (0.25, ("left_toes", "right_toes")), (0.0, ("left_foot", "right_foot")),
    (-0.25, ("left_heel", "right_heel"))])
def test_a_sole_touching_ahead_behind_or_along_is_toes_heel_or_foot(model, lean, expected):
    assert floor_contacts(model, _on_toes(model, lean)) == (expected, ())


def test_lying_on_the_back_touches_with_the_back_not_the_chest(model):
    data = mujoco.MjData(model)
    data.qpos[3:7] = [np.cos(-np.pi / 4), 0.0, np.sin(-np.pi / 4), 0.0]
    seat_single(model, data)
    data = _held(model, data.qpos.copy(), 1.5)
    assert floor_contacts(model, data) == (("back", "left_heel", "right_heel"), ())


def _held(model, qpos: np.ndarray, seconds: float) -> mujoco.MjData:
    """``qpos`` dropped onto the floor and held by joint PD on its own joints."""
    qadr = np.array([model.joint(n).qposadr[0] for n in constants.JOINT_NAMES])
    dadr = np.array([model.joint(n).dofadr[0] for n in constants.JOINT_NAMES])
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    target = qpos[qadr].copy()
    for _ in range(int(round(seconds / model.opt.timestep))):
        data.ctrl[:] = pd_torque(target, data.qpos[qadr], data.qvel[dadr])
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return data


@pytest.mark.parametrize("name", ["knee_chest", "hands_knees", "kneel_upright"])
def test_a_held_keyframe_has_the_margin_of_its_own_check(model, robot, ik, name):
    keyframe = CONTACT_KEYFRAMES[name]
    qpos = ik.solve(keyframe).qpos
    own = static_feasibility(robot, qpos, keyframe.contacts)
    assert own.feasible
    # pressed 1 mm into the floor: MuJoCo reports exactly the keyframe's contacts, and
    # the check on them is the keyframe's own
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    data.qpos[2] -= 0.001
    mujoco.mj_forward(model, data)
    sample = state_margin(robot, model, data)
    assert sample.contacts == tuple(sorted(keyframe.contacts)) and sample.unmapped == ()
    assert sample.feasible
    assert sample.margin == pytest.approx(1.0 - own.worst_ratio, abs=1e-9)
    # held still in MuJoCo for 1.5 s it rests on the same contacts with nearly that margin
    held = _held(model, data.qpos.copy(), 1.5)
    mujoco.mj_subtreeVel(model, held)
    assert np.linalg.norm(held.subtree_linvel[1]) < 0.02
    sample = state_margin(robot, model, held)
    assert sample.contacts == tuple(sorted(keyframe.contacts))
    assert sample.feasible
    assert sample.margin == pytest.approx(1.0 - own.worst_ratio, abs=0.02)


def _on_toes(model, lean: float) -> mujoco.MjData:
    """The default standing pose pitched by ``lean`` [rad] (forward > 0), its lowest
    point 1 mm into the floor."""
    data = mujoco.MjData(model)
    data.qpos[3:7] = [np.cos(lean / 2), 0.0, np.sin(lean / 2), 0.0]
    data.qpos[7:] = constants.DEFAULT_JOINT_POS
    seat_single(model, data, clearance=-0.001)
    mujoco.mj_forward(model, data)
    return data


def test_com_ahead_of_the_toes_is_unsupported_in_the_table(model, robot):
    data = _on_toes(model, 0.25)
    assert floor_contacts(model, data) == (("left_toes", "right_toes"), ())
    sample = state_margin(robot, model, data, phase="hand/made")
    assert not sample.feasible and not sample.supported
    assert sample.reason.startswith("base unsupported: the contacts leave a wrench of ")
    # the CoM is d ahead of the toe line: m g at the line would leave m g d about the
    # CoM; the least-squares slack leaves a sizeable part of it
    toes = model.body("left_ankle_roll_link").id
    sole_front = (data.xpos[toes] + data.xmat[toes].reshape(3, 3) @ [0.17, 0.0, -0.045])[0]
    mujoco.mj_subtreeVel(model, data)
    lever = float(data.subtree_com[1, 0] - sole_front)
    assert lever > 0.05
    assert 0.1 * robot.mass * GRAVITY * lever < sample.leftover_moment
    assert sample.leftover_moment <= robot.mass * GRAVITY * lever + 1e-6
    upright = state_margin(robot, model, _on_toes(model, 0.0))
    assert upright.contacts == ("left_foot", "right_foot") and upright.feasible
    result = {"move": "tuck", "seed": 0, "start": "prone", "start_state": "prone",
              "arrived": False, "samples": [sample]}
    row = margin_table([result]).splitlines()[3]
    assert row.startswith("| hand/made | 1 | 0 % | — | ")
    assert row.endswith(" | base unsupported |")


def test_the_tuck_is_checked_along_its_way_and_ends_feasible(model):
    data = move_start(model, "tuck", seed=0)
    single = SingleMove("tuck")
    samples = margins_along(model, data, single, every=0.1)
    assert single.status == "arrived" and single.start_state == "prone"
    phase = ALL_MOVES["tuck"].phases[0]
    # one sample per 0.1 s of the phase and its hold
    assert len(samples) == round((phase.duration + phase.hold) / 0.1)
    np.testing.assert_allclose(np.diff([s.time for s in samples]), 0.1, atol=model.opt.timestep)
    assert samples[-1].feasible and samples[-1].margin > 0.9
    assert {"left_knee", "right_knee"} <= set(samples[-1].contacts)
    (summary,) = summarise(samples)
    assert summary.phase == "tuck/knee_chest" and summary.samples == len(samples)
    assert summary.feasible_fraction == pytest.approx(np.mean([s.feasible for s in samples]))


def test_unknown_move_messages(model, capsys):
    with pytest.raises(ValueError) as err:
        SingleMove("fly")
    assert str(err.value) == UNKNOWN_MOVE
    with pytest.raises(ValueError) as err:
        move_margins(["tuck", "fly"])
    assert str(err.value) == UNKNOWN_MOVE
    with pytest.raises(ValueError) as err:
        move_margins(["tuck"], seeds=[])
    assert str(err.value) == "name at least one seed"
    with pytest.raises(ValueError) as err:
        margins_along(model, mujoco.MjData(model), SingleMove("tuck"), every=0.0)
    assert str(err.value) == "every must be > 0, got 0.0"
    assert main(["getup", "margins", "--move", "fly"]) == 2
    assert capsys.readouterr().err == f"error: {UNKNOWN_MOVE}\n"


def test_cli_prints_the_table_and_writes_every_state(tmp_path, capsys):
    out, plot = tmp_path / "m.csv", tmp_path / "m.png"
    assert main(["getup", "margins", "--move", "tuck", "--seed", "0", "1", "--out", str(out),
                 "--plot", str(plot)]) == 0
    text = capsys.readouterr().out
    assert ("| **tuck** from prone starts (seeds 0 1; settled prone 2) | | | | | knee_chest "
            "reached 2/2 |") in text
    assert "\n| tuck/knee_chest | 120 | " in text  # one row pooling both runs
    with out.open() as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 120 and {r["phase"] for r in rows} == {"tuck/knee_chest"}
    assert [r["seed"] for r in rows] == ["0"] * 60 + ["1"] * 60
    assert plot.stat().st_size > 1000
