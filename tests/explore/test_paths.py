"""Shortest paths on the known-free grid: costs, clearance, unreachable cells, the start snapped off a wall, walls the
robot touched that its map does not show."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.explore.paths import cost_field, mark_contacts, traversable_cells
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec

GRID = GridSpec(0.1, 0.0, 0.0, 60, 20)


def _corridor() -> np.ndarray:
    """A 6 m × 2 m free corridor walled all round (row 0, row 19, col 0, col 59 occupied)."""
    image = np.full(GRID.shape, FREE, np.float32)
    image[[0, -1], :] = OCCUPIED
    image[:, [0, -1]] = OCCUPIED
    return image


def test_cost_along_a_corridor_is_its_length() -> None:
    field = cost_field(_corridor(), GRID, np.array([1.05, 1.05]), robot_radius_m=0.2, margin_m=0.05)
    assert field.start == (10, 10)
    # the middle row is far from the walls (clearance >= 0.9 m): one unit per cell, 0.1 m
    assert field.cost_m[10, 50] == pytest.approx(4.0)
    # within robot radius + 0.4 m of a wall a cell costs more (up to 5 units): paths keep to the middle
    assert field.cost_m[10, 5] == pytest.approx(0.5 + 0.05)
    path = field.path_to(np.array([10, 50]))
    np.testing.assert_allclose(path[0], [1.05, 1.05])
    np.testing.assert_allclose(path[-1], [5.05, 1.05])
    assert np.all(np.hypot(*np.diff(path, axis=0).T) <= 0.1 * np.sqrt(2) + 1e-9)


def test_walls_and_unknown_cells_are_not_traversable() -> None:
    image = _corridor()
    image[:, 30] = OCCUPIED  # a wall across the corridor
    image[5:15, 40:45] = UNKNOWN
    traversable, clearance = traversable_cells(image, 0.1, 0.2, 0.05)
    assert not traversable[:, 28:33].any()  # within 0.25 m of the wall
    assert not traversable[5:15, 40:45].any() and clearance[10, 42] > 0.5  # unknown: no obstacle, yet not free
    field = cost_field(image, GRID, np.array([0.55, 1.05]), 0.2, 0.05)
    assert np.isinf(field.cost_m[:, 31:]).all() and np.isfinite(field.cost_m[10, 20])
    with pytest.raises(ValueError, match="not reachable"):
        field.path_to(np.array([10, 50]))


def test_start_next_to_a_wall_snaps_to_the_nearest_traversable_cell() -> None:
    field = cost_field(_corridor(), GRID, np.array([0.15, 0.15]), 0.2, 0.05)
    assert field.start is not None and field.traversable[field.start]
    assert np.hypot(field.start[0] - 1, field.start[1] - 1) * 0.1 <= 0.6
    nowhere = cost_field(np.full(GRID.shape, OCCUPIED, np.float32), GRID, np.array([1.0, 1.0]), 0.2, 0.05)
    assert nowhere.start is None and np.isinf(nowhere.cost_m).all()


def test_a_touched_wall_blocks_the_paths_through_it() -> None:
    image = _corridor()
    image[1:5, 30] = OCCUPIED  # a stub leaves the corridor open from row 5 on
    start = np.array([1.05, 1.05])
    assert np.isfinite(cost_field(image, GRID, start, 0.2, 0.05).cost_m[10, 50])
    # the robot felt walls across the gap at x = 3.05 m, where its map shows free space
    contacts = np.array([[3.05, y] for y in (0.55, 0.85, 1.15, 1.45, 1.75)] + [[99.0, 99.0]])  # one off the grid
    marked = mark_contacts(image, GRID, contacts)
    assert (marked[5:18:3, 30] == OCCUPIED).all() and (image[5:19, 30] == FREE).all()  # the map itself is left as is
    assert (marked != image).sum() == 5
    assert np.isinf(cost_field(marked, GRID, start, 0.2, 0.05).cost_m[10, 50])
    assert mark_contacts(image, GRID, np.zeros((0, 2))) is image


def test_costs_between_places_follow_the_same_paths() -> None:
    image = _corridor()
    image[1:15, 30] = OCCUPIED  # a wall across the corridor, open at its top (rows 15-18)
    field = cost_field(image, GRID, np.array([1.05, 1.05]), robot_radius_m=0.2, margin_m=0.05)
    cells = np.array([[10, 10], [10, 50], [10, 20]])
    between = field.costs_between(cells)
    np.testing.assert_allclose(between, between.T)
    assert np.all(np.diag(between) == 0)
    np.testing.assert_allclose(between[0], field.cost_m[cells[:, 0], cells[:, 1]], rtol=1e-6)  # from the robot's cell
    assert between[1, 2] > 3.0  # round the wall's end: farther than the 3 m straight line
    assert field.costs_between(cells[:1]).shape == (1, 1)


def test_a_robot_its_map_pinches_in_is_not_closed_in_with_its_footprint_free() -> None:
    """The map draws the corridor a little too narrow on both sides of the robot (a SLAM map's wall specks): the
    cells it fits in end short of it, so it can reach nothing past them; with the cells under its own footprint free
    (it stands there, so it fits) the corridor beyond is reachable again.  Walls stay walls."""
    image = _corridor()
    image[[7, 13, 7, 13], [28, 28, 32, 32]] = OCCUPIED  # specks 0.6 m apart, 0.2 m on either side of the robot
    robot = np.array([3.05, 1.05])  # cell (10, 30)
    pinched = cost_field(image, GRID, robot, robot_radius_m=0.35, margin_m=0.0)
    assert np.isfinite(pinched.cost_m[10, 30]) and np.isinf(pinched.cost_m[10, 50]) and np.isinf(pinched.cost_m[10, 10])
    freed = cost_field(image, GRID, robot, robot_radius_m=0.35, margin_m=0.0, footprint=True)
    assert np.isfinite(freed.cost_m[10, 50]) and np.isfinite(freed.cost_m[10, 10])
    assert not freed.traversable[image == OCCUPIED].any()
