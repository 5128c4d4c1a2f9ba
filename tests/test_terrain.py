"""Terrain: parsed with one-line errors, built exactly as configured (MuJoCo's own ray
casts against :func:`ground_height`), starts seated on it without penetration, and the
success criterion measured above the ground under the robot."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from hybrid_recovery.controllers import make
from hybrid_recovery.evaluation.scenario import TERRAIN_LADDER, Scenario, terrain_protocol
from hybrid_recovery.evaluation.trial import eval_model, run_trial, start_state
from hybrid_recovery.robot import constants
from hybrid_recovery.robot.mjcf import default_qpos
from hybrid_recovery.sim.initial_states import quat_mul
from hybrid_recovery.sim.terrain import Terrain, ground_height, parse_terrain, rough_heights
from hybrid_recovery.sim.terrain_model import TERRAIN_GEOM, seat_on_terrain, slope_quat


@pytest.mark.parametrize(("text", "expected"), [
    ("flat", Terrain()),
    ("slope:10", Terrain("slope", slope=10.0)),
    ("slope:-7.5:90", Terrain("slope", slope=-7.5, heading=90.0)),
    ("rough:5", Terrain("rough", height=0.05)),
    ("step:10", Terrain("step", height=0.10)),
])
def test_terrains_parse_and_print_back(text, expected):
    assert parse_terrain(text) == expected
    assert parse_terrain(expected.text) == expected


@pytest.mark.parametrize(("text", "message"), [
    ("slope:91", "terrain 'slope:91': the slope must be within ±45 deg, got 91"),
    ("rough:-1", "terrain 'rough:-1': the height must be 0 to 20 cm, got -1"),
    ("step:31", "terrain 'step:31': the height must be 0 to 30 cm, got 31"),
    ("mud", "unknown terrain 'mud': use flat, slope:DEG[:HEADING], rough:CM or step:CM"),
    ("slope", "terrain 'slope': use flat, slope:DEG[:HEADING], rough:CM or step:CM"),
    ("slope:nan", "terrain 'slope:nan': 'nan' is not a finite number"),
    ("rough:abc", "terrain 'rough:abc': 'abc' is not a finite number"),
])
def test_bad_terrains_are_refused_in_one_line(text, message):
    with pytest.raises(ValueError) as info:
        parse_terrain(text)
    assert str(info.value) == message
    with pytest.raises(ValueError) as info:
        Scenario("supine", terrain=text)
    assert str(info.value) == message


@pytest.mark.parametrize("text", ["slope:10:30", "slope:-15", "rough:5", "step:10"])
def test_the_ground_is_where_ground_height_says(text):
    terrain = parse_terrain(text)
    model = eval_model(None, 0.005, False, "default", terrain=text)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geom = np.array([-1], dtype=np.int32)
    for x, y in np.random.default_rng(1).uniform(-3, 3, (100, 2)):
        depth = mujoco.mj_ray(model, data, np.array([x, y, 5.0]), np.array([0.0, 0.0, -1.0]),
                              None, 1, -1, geom)
        expected = ground_height(terrain, np.array([x, y]))
        assert 5.0 - depth == pytest.approx(expected, abs=1e-7)  # MuJoCo's heights: float32


def test_slopes_and_heights_are_exactly_as_configured():
    model = eval_model(None, 0.005, False, "default", terrain="slope:10:30")
    normal = model.geom("floor").quat
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, normal)
    n = rot.reshape(3, 3)[:, 2]
    assert np.degrees(np.arccos(n[2])) == pytest.approx(10.0, abs=1e-9)
    assert np.degrees(np.arctan2(-n[1], -n[0])) == pytest.approx(30.0, abs=1e-9)  # rises there
    heights = rough_heights(parse_terrain("rough:5"))
    assert heights.min() == 0.0 and heights.max() == pytest.approx(0.05, abs=1e-15)
    rough = eval_model(None, 0.005, False, "default", terrain="rough:5")
    assert rough.hfield_size[0, 2] == pytest.approx(0.05)
    assert rough.hfield_data.min() == 0.0 and rough.hfield_data.max() == pytest.approx(1.0)
    step = eval_model(None, 0.005, False, "default", terrain="step:10")
    box = step.geom(TERRAIN_GEOM)
    assert box.pos[2] + box.size[2] == pytest.approx(0.10)


@pytest.mark.parametrize("text", ["slope:15:45", "rough:5", "step:10"])
@pytest.mark.parametrize("pose", ["standing", "sitting", "supine"])
def test_starts_are_seated_on_the_terrain_without_penetration(text, pose):
    terrain = parse_terrain(text)
    model = eval_model(None, 0.005, False, "default", terrain=text)
    data = mujoco.MjData(model)
    for seed in range(3):
        data.qpos[:] = start_state(Scenario(pose, seed=seed), None, "default")
        seat_on_terrain(model, data, terrain, clearance=0.005)
        mujoco.mj_forward(model, data)
        assert data.ncon == 0, "a geom penetrates the ground"
        if terrain.kind == "slope":  # exact: 6 mm lower and it touches
            data.qpos[2] -= 0.006 / np.cos(np.radians(15))
            mujoco.mj_forward(model, data)
            assert data.ncon > 0
        else:  # above the ground by no more than the terrain's height
            low = data.geom_xpos[:, 2] - model.geom_rbound
            robot = model.geom_bodyid > 0
            gap = low[robot] - ground_height(terrain, data.geom_xpos[robot, :2])
            assert gap.min() < terrain.height + 0.005 + 1e-9


class _Hold:
    """PD targets held at a fixed pose."""

    name, physics_dt, torque_control, output = "hold", 0.005, False, "position"

    def __init__(self, joints: np.ndarray) -> None:
        self.joints = joints

    def reset(self, model, data) -> None:
        del model, data

    def __call__(self, model, data) -> np.ndarray:
        return self.joints

    def info(self) -> dict:
        return {}


def _standing_on(slope: str, x: float) -> tuple[np.ndarray, np.ndarray]:
    """A standing start facing up the slope at (x, 0): ankles pitched to the plane, the body
    upright after :func:`seat_on_terrain` turns it with the plane."""
    model = eval_model(None, 0.005, False, "default")
    joints = constants.DEFAULT_JOINT_POS.copy()
    joints[[4, 10]] -= np.radians(parse_terrain(slope).slope)
    qpos = default_qpos(model)
    qpos[7:] = joints
    qpos[0] = x
    qpos[3:7] = quat_mul(slope_quat(parse_terrain(slope)) * [1, -1, -1, -1], qpos[3:7])
    return qpos, joints


@pytest.mark.parametrize("x", [0.0, -3.0])
def test_standing_still_on_a_10_degree_plane_is_a_success(x):
    """At x = −3 m the CoM is 0.37 m above z = 0 (0.92 m above the plane under it)."""
    qpos, joints = _standing_on("slope:10", x)
    result = run_trial(_Hold(joints), Scenario("standing", duration=2.0, terrain="slope:10"),
                       start_qpos=qpos, record=True)
    com = result["trace"]["com"]
    assert result["success"] and result["standing_at_end"] and not result["fell"]
    if x < 0:
        assert (com[:, 2] < constants.UPRIGHT_COM_HEIGHT).all()


def test_lying_on_a_10_degree_plane_is_not_a_success():
    result = run_trial(make("zero"), Scenario("supine", duration=2.0, terrain="slope:10"))
    assert not result["success"] and not result["standing_at_end"] and result["fell"]


def test_the_qp_declines_terrain_with_a_reason():
    result = run_trial(make("qp"), Scenario("standing", duration=2.0, terrain="slope:5"))
    assert result["declined"] == ("qp declines slope:5: its QP models the ground as the "
                                  "plane z = 0 (contact normal +z, friction cone about it)")
    assert result["not_applicable"] and not result["success"]
    flat = run_trial(make("qp"), Scenario("standing", duration=1.0, terrain="slope:0"))
    assert "declined" not in flat


def test_the_hybrid_runs_on_a_slope_as_the_policy():
    """Its supervisor keeps the QP out where the ground is tilted: no hand-over to it."""
    scenario = Scenario("standing", duration=1.5, terrain="slope:10")
    result = run_trial(make("hybrid"), scenario)
    assert "declined" not in result
    assert "to_qp" not in [kind for _, kind, _ in result["controller_info"]["switches"]]


def test_the_terrain_protocol_pairs_its_starts_across_terrains():
    scenarios = terrain_protocol(2, poses=("supine", "sitting"))
    assert len(scenarios) == 2 * 2 * len(TERRAIN_LADDER)
    seeds = {t: [s.seed for s in scenarios if s.terrain == t] for t in TERRAIN_LADDER}
    assert len({tuple(v) for v in seeds.values()}) == 1 and len(set(seeds["flat"])) == 4
    assert len({s.key for s in scenarios}) == len(scenarios)
    assert Scenario("supine").key == "supine|0|0.0000|0|1|0.1|20|0|1"  # flat keys unchanged
