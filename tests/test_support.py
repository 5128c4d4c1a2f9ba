"""Support polygons, signed distances and the centre of pressure against known answers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from hybrid_recovery.dynamics.support import (
    center_of_pressure,
    signed_distance,
    signed_distance_batched,
    support_polygon,
    zero_moment_point,
)

SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
TRIANGLE = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]])  # incircle r = 1 at (1, 1)


def _area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_hull_of_square_drops_interior_duplicate_and_collinear_points() -> None:
    points = np.vstack([SQUARE, [[0.5, 0.5], [0.5, 0.0], [1.0, 1.0], [0.2, 0.7]]])
    hull = support_polygon(points)
    assert hull.shape == (4, 2)
    assert {tuple(v) for v in hull} == {tuple(v) for v in SQUARE}
    assert _area(hull) == pytest.approx(1.0)  # positive: counter-clockwise


def test_hull_ignores_z() -> None:
    points = np.column_stack([SQUARE, [0.0, 0.3, -0.2, 1.0]])
    assert _area(support_polygon(points)) == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("points", "expected"),
    [
        ([[0.3, -0.2]], [[0.3, -0.2]]),
        ([[0.3, -0.2], [0.3, -0.2], [0.3, -0.2]], [[0.3, -0.2]]),
        ([[1.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [1.0, 1.0]]),
        ([[2.0, 2.0], [0.0, 0.0], [1.0, 1.0], [0.5, 0.5], [2.0, 2.0]], [[0.0, 0.0], [2.0, 2.0]]),
        ([[0.0, 1.0], [0.0, -1.0], [0.0, 0.2]], [[0.0, -1.0], [0.0, 1.0]]),
    ],
)
def test_hull_of_degenerate_sets(points: list, expected: list) -> None:
    np.testing.assert_allclose(support_polygon(np.array(points)), expected)


def test_hull_matches_qhull_on_random_sets() -> None:
    rng = np.random.default_rng(0)
    for _ in range(50):
        points = rng.normal(size=(rng.integers(3, 30), 2))
        hull = support_polygon(points)
        reference = points[ConvexHull(points).vertices]  # counter-clockwise in 2-D
        assert {tuple(v) for v in hull} == {tuple(v) for v in reference}
        assert _area(hull) > 0.0


def test_hull_errors() -> None:
    with pytest.raises(ValueError, match="^support_polygon needs at least one contact point$"):
        support_polygon(np.zeros((0, 3)))
    with pytest.raises(
        ValueError, match=r"^points must have shape \(M, 2\) or \(M, 3\), got \(4,\)$"
    ):
        support_polygon(np.zeros(4))


@pytest.mark.parametrize(
    ("polygon", "point", "expected"),
    [
        (SQUARE, [0.5, 0.5], -0.5),
        (SQUARE, [0.5, 0.1], -0.1),
        (SQUARE, [0.9, 0.5], -0.1),
        (SQUARE, [0.5, 0.0], 0.0),
        (SQUARE, [1.0, 1.0], 0.0),
        (SQUARE, [2.0, 0.5], 1.0),
        (SQUARE, [-0.5, 0.5], 0.5),
        (SQUARE, [2.0, 2.0], np.sqrt(2.0)),
        (TRIANGLE, [1.0, 1.0], -1.0),
        (TRIANGLE, [4.0, 3.0], 12.0 / 5.0),  # to the hypotenuse 3x + 4y = 12
        (TRIANGLE, [-3.0, -4.0], 5.0),
        (np.array([[1.0, 2.0]]), [4.0, 6.0], 5.0),
        (np.array([[1.0, 2.0]]), [1.0, 2.0], 0.0),
        (np.array([[0.0, 0.0], [2.0, 0.0]]), [1.0, 0.0], 0.0),
        (np.array([[0.0, 0.0], [2.0, 0.0]]), [1.0, -0.5], 0.5),
        (np.array([[0.0, 0.0], [2.0, 0.0]]), [5.0, 4.0], 5.0),
    ],
)
def test_signed_distance_known_answers(polygon: np.ndarray, point: list, expected: float) -> None:
    d = signed_distance(np.array(point), polygon)
    assert isinstance(d, float)
    assert d == pytest.approx(expected, abs=1e-12)


def test_signed_distance_against_qhull_and_sampled_boundary() -> None:
    """Inside: Qhull's facet planes; outside: the nearest of densely sampled boundary points."""
    rng = np.random.default_rng(1)
    for _ in range(20):
        points = rng.uniform(-1.0, 1.0, size=(12, 2))
        qhull = ConvexHull(points)
        polygon = support_polygon(points)
        query = rng.uniform(-2.0, 2.0, size=(200, 2))
        d = signed_distance(query, polygon)
        assert d.shape == (200,)
        plane = query @ qhull.equations[:, :2].T + qhull.equations[:, 2]  # n·p + b, outward
        inside = plane.max(axis=1) <= 0.0
        np.testing.assert_allclose(d[inside], plane.max(axis=1)[inside], atol=1e-12)
        s = np.linspace(0.0, 1.0, 2001)[:, None, None]
        boundary = (polygon + s * (np.roll(polygon, -1, axis=0) - polygon)).reshape(-1, 2)
        nearest = np.linalg.norm(query[~inside, None] - boundary, axis=-1).min(axis=1)
        np.testing.assert_allclose(d[~inside], nearest, atol=1e-3)
        assert np.all(d[~inside] <= nearest + 1e-12) and np.all(d[~inside] > 0.0)


def _random_contact_set(rng: np.random.Generator) -> np.ndarray:
    """1–8 points: general, one repeated point, collinear, or on a coarse grid."""
    m = int(rng.integers(1, 9))
    points = rng.uniform(-0.5, 0.5, size=(m, 2))
    kind = rng.integers(4)
    if kind == 1:
        points[:] = points[0]
    elif kind == 2:
        points = points[0] + rng.uniform(-1.0, 1.0, size=(m, 1)) * rng.uniform(-0.3, 0.3, 2)
    elif kind == 3:
        points = np.round(points * 4.0) / 4.0
    return points


def test_batched_matches_scalar_including_degenerate_sets() -> None:
    rng = np.random.default_rng(2)
    n_env, m = 3000, 10
    contacts = rng.uniform(-3.0, 3.0, size=(n_env, m, 3))  # inactive slots hold junk
    mask = np.zeros((n_env, m), dtype=bool)
    query = rng.uniform(-0.6, 0.6, size=(n_env, 2))
    expected = np.empty(n_env)
    for i in range(n_env):
        points = _random_contact_set(rng)
        slots = rng.choice(m, size=len(points), replace=False)
        contacts[i, slots, :2], mask[i, slots] = points, True
        if rng.random() < 0.2:
            query[i] = points[rng.integers(len(points))]  # on a vertex
        expected[i] = signed_distance(query[i], support_polygon(points))
    got = signed_distance_batched(query, contacts, mask)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    assert np.sum(got < 0.0) > 100 and np.sum(got > 0.0) > 1000


def test_batched_without_contact() -> None:
    contacts = np.zeros((3, 4, 2))
    mask = np.array([[False] * 4, [True, False, False, False], [False] * 4])
    query = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 0.0]])
    np.testing.assert_allclose(signed_distance_batched(query, contacts, mask), [1.0, 5.0, 1.0])
    far = signed_distance_batched(query, contacts, mask, no_contact=np.inf)
    assert np.isinf(far[0]) and far[1] == 5.0
    assert signed_distance_batched(query, np.zeros((3, 0, 2)), np.zeros((3, 0), bool))[0] == 1.0


def test_cop_of_two_equal_forces_is_the_midpoint() -> None:
    positions = np.array([[0.1, 0.2, 0.0], [0.5, -0.2, 0.0]])
    forces = np.array([[0.0, 0.0, 300.0], [0.0, 0.0, 300.0]])
    np.testing.assert_allclose(center_of_pressure(positions, forces), [0.3, 0.0], atol=1e-12)


def test_cop_of_coplanar_contacts_is_the_pressure_weighted_mean() -> None:
    rng = np.random.default_rng(3)
    for height in (0.0, 0.25):
        positions = np.column_stack([rng.normal(size=(6, 2)), np.full(6, height)])
        forces = np.column_stack([rng.normal(size=(6, 2)) * 50.0, rng.uniform(10, 200, 6)])
        mean = forces[:, 2] @ positions[:, :2] / forces[:, 2].sum()
        np.testing.assert_allclose(center_of_pressure(positions, forces, height), mean)


def test_zmp_of_a_single_raised_contact_lies_on_its_line_of_action() -> None:
    position, force = np.array([0.2, -0.1, 0.4]), np.array([30.0, -20.0, 100.0])
    zmp = center_of_pressure(position[None], force[None], height=0.0)
    np.testing.assert_allclose(zmp, (position + (0.0 - 0.4) / 100.0 * force)[:2])


def test_cop_is_batched() -> None:
    positions = np.zeros((5, 2, 3))
    positions[:, 1, 0] = 1.0
    forces = np.zeros((5, 2, 3))
    forces[..., 2] = [[1.0, 3.0]]
    np.testing.assert_allclose(center_of_pressure(positions, forces), np.tile([0.75, 0.0], (5, 1)))


def test_cop_errors() -> None:
    positions = np.zeros((2, 3))
    with pytest.raises(
        ValueError, match="^center_of_pressure: the contacts carry no normal force$"
    ):
        center_of_pressure(positions, np.array([[0.0, 0.0, 10.0], [0.0, 0.0, -10.0]]))
    with pytest.raises(
        ValueError, match=r"^zero_moment_point: the contacts carry no normal force \(f_z <= 0\)$"
    ):
        zero_moment_point(np.array([1.0, 0.0, 0.0]), np.zeros(3))


def test_batched_rejects_shapes_that_do_not_fit() -> None:
    contacts, mask = np.zeros((3, 4, 3)), np.ones((3, 4), dtype=bool)
    for point, c, m in ((np.zeros((2, 2)), contacts, mask), (np.zeros((3, 3)), contacts, mask),
                        (np.zeros((3, 2)), contacts[:, :3], mask),
                        (np.zeros((3, 2)), np.zeros((3, 4, 4)), mask),
                        (np.zeros((3, 2)), contacts, mask[0])):
        with pytest.raises(ValueError, match="signed_distance_batched needs"):
            signed_distance_batched(point, c, m)
