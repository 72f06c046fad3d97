"""The taut-rope prediction the scripted gestures plan their carries with (viscera.tasks.carry):
inextensible legs, untouched rope beyond them, refusals where tissue would stretch."""

import numpy as np
import pytest

from viscera.tasks import carry

SPACING = 0.03  # m between axis points, as the tasks observe 3 m with 100 points


def straight(count: int = 21) -> np.ndarray:
    x = (np.arange(count) - count // 2) * SPACING
    return np.column_stack([x, np.zeros(count), np.full(count, 0.0125)])


def serpentine(count: int = 61, amplitude: float = 0.04, wavelength: float = 0.12) -> np.ndarray:
    """A wavy rope along x with its points SPACING apart along it (resampled by arc length)."""
    x = np.linspace(-1.0, 1.0, 20001)
    y = amplitude * np.sin(2.0 * np.pi * x / wavelength)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    s = (np.arange(count) - count // 2) * SPACING + arc[-1] / 2.0
    return np.column_stack([np.interp(s, arc, x), np.interp(s, arc, y), np.full(count, 0.0125)])


def leg_lengths(axis: np.ndarray, points: np.ndarray, index: int) -> list[tuple[float, float]]:
    """Per side of `index`, from it to the first unmoved point: (the predicted polyline's
    length, the rope's length)."""
    moved = np.flatnonzero(np.any(points != axis[:, :2], axis=1))
    result = []
    for span in (np.arange(moved.min() - 1, index + 1), np.arange(index, moved.max() + 2)):
        predicted = np.linalg.norm(np.diff(points[span], axis=0), axis=1).sum()
        rope = np.linalg.norm(np.diff(axis[span], axis=0), axis=1).sum()
        result.append((predicted, rope))
    return result


def test_a_taut_rope_pinned_at_its_ends_cannot_be_carried_sideways():
    """A straight rope has no slack: any sideways carry stretches it to its pinned ends."""
    axis = straight()
    assert carry.carried(axis, 10, axis[10, :2] + (0.0, 0.05)) is None


def test_rope_that_rises_and_falls_is_rope_too():
    """Rope is measured along the axis in 3-D: a rope straight in plan but rising and falling
    2 cm between points (3.6 cm of rope per 3 cm in plan) has the slack for a 5 cm sideways
    carry, taken up to the first points whose rope reaches (j >= 5 / 2.0, the third on each side)."""
    axis = straight()
    axis[::2, 2] += 0.02
    points = carry.carried(axis, 10, axis[10, :2] + (0.0, 0.05))
    assert points is not None
    moved = np.flatnonzero(np.any(points != axis[:, :2], axis=1))
    np.testing.assert_array_equal(moved, np.arange(8, 13))  # 10 and two on each side; 7 and 13 anchor


def test_a_carry_moves_only_the_rope_it_needs_and_never_stretches_it():
    """On a wavy rope a short carry pulls taut legs back to the first points with rope enough:
    beyond them nothing moves, and no leg is longer than the rope it is made of."""
    axis = serpentine()
    index = 30
    drop = axis[index, :2] + (0.0, 0.06)
    points = carry.carried(axis, index, drop)
    assert points is not None
    moved = np.flatnonzero(np.any(points != axis[:, :2], axis=1))
    assert moved.min() > 0 and moved.max() < len(axis) - 1  # the ends stay
    assert np.all(np.diff(moved) == 1)  # one contiguous stretch around the carried point
    np.testing.assert_array_equal(points[index], drop)
    for predicted, rope in leg_lengths(axis, points, index):
        assert predicted <= rope + 1e-12
    # each leg ends at the first point whose rope to the carried point reaches it in a line
    for step, last in ((-1, moved.min()), (1, moved.max())):
        anchor = last + step
        rope = np.linalg.norm(np.diff(axis[min(anchor, index):max(anchor, index) + 1], axis=0), axis=1).sum()
        assert rope >= np.linalg.norm(drop - axis[anchor, :2])
        shorter = np.linalg.norm(np.diff(axis[min(last, index):max(last, index) + 1], axis=0), axis=1).sum()
        assert shorter < np.linalg.norm(drop - axis[last, :2])


def test_the_mesentery_refuses_a_carry_away_from_its_root_and_allows_one_towards_it():
    """Each point is tethered to its root: a carry that takes a moved point beyond the reach (and
    beyond where it already is) is refused; the same carry towards the roots is not."""
    axis = serpentine()
    roots = np.column_stack([axis[:, 0], np.full(len(axis), -0.10), np.zeros(len(axis))])  # a root line 10 cm off
    reach = float(np.max(np.linalg.norm(axis - roots, axis=1))) + 0.005
    index = 30
    away = carry.carried(axis, index, axis[index, :2] + (0.0, 0.06), roots, reach)
    towards = carry.carried(axis, index, axis[index, :2] - (0.0, 0.06), roots, reach)
    assert away is None
    assert towards is not None
    assert carry.carried(axis, index, axis[index, :2] + (0.0, 0.06), roots, np.inf) is not None


def test_a_point_already_beyond_the_mesentery_may_move_but_not_farther():
    """Points the settled bowel already holds beyond the reach (the tasks' tissue draws
    mesenteries up to 21 cm; the planner assumes 15) may be carried towards their roots, not away."""
    axis = serpentine()
    roots = np.column_stack([axis[:, 0], np.full(len(axis), -0.20), np.zeros(len(axis))])  # every point 16 to 24 cm off
    assert np.linalg.norm(axis - roots, axis=1).min() > 0.15
    assert carry.carried(axis, 30, axis[30, :2] - (0.0, 0.03), roots, 0.15) is not None
    assert carry.carried(axis, 30, axis[30, :2] + (0.0, 0.03), roots, 0.15) is None


def test_coverage_and_clearance_by_distance():
    """A tube of radius r along x covers the cells within r of its axis; a point's clearance from
    a rectangle is its distance to the nearest edge or corner."""
    points = np.array([[-0.1, 0.0], [0.1, 0.0]])
    cells = np.array([[0.0, 0.0], [0.05, 0.0124], [0.05, 0.0126], [0.2, 0.0]])
    np.testing.assert_array_equal(carry.covered(points, cells, 0.0125), [True, True, False, False])
    assert carry.clearance(np.array([[0.05, 0.0], [0.0, 0.06]]), (0.0, 0.0), (0.02, 0.015)) == pytest.approx(0.03)
    assert carry.clearance(np.array([[0.05, 0.055]]), (0.0, 0.0), (0.02, 0.015)) == pytest.approx(0.05)
    assert carry.clearance(np.array([[0.01, 0.0]]), (0.0, 0.0), (0.02, 0.015)) == 0.0


def test_the_roots_lie_along_the_root_line_in_the_bowels_order():
    line = np.array([[-0.08, 0.08, 0.0], [0.08, -0.08, 0.0]])
    roots = carry.mesentery_roots(line, 5)
    np.testing.assert_allclose(roots[[0, 2, 4]], [line[0], line.mean(axis=0), line[1]])


def test_a_finer_axis_is_resampled_evenly_along_its_length():
    """The planner's resampling keeps the ends and spaces the points evenly along the polyline,
    whatever the spacing it was given."""
    corner = np.array([[0.0, 0.0, 0.01], [0.03, 0.0, 0.01], [0.3, 0.0, 0.01], [0.3, 0.3, 0.01]])
    points = carry.resampled(corner, 7)  # 0.6 m of polyline: 0.1 m apart
    np.testing.assert_allclose(points[[0, -1]], corner[[0, -1]])
    np.testing.assert_allclose(points[:, 0], [0.0, 0.1, 0.2, 0.3, 0.3, 0.3, 0.3], atol=1e-12)
    np.testing.assert_allclose(points[:, 1], [0.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3], atol=1e-12)
