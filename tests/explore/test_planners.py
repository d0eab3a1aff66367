"""The planning view: the best particle's map pooled for planning, coarser in a large building; scores that see the
whole tour."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.explore.frontiers import Viewpoints
from mcnkit.explore.paths import cost_field
from mcnkit.explore.planners import planning_view, regret_scores, tour_scores
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import FREE, OCCUPIED, GridSpec


def _lineage() -> LineageMap:
    """One 360-beam scan from the origin inside a 6 m × 6 m square room (walls 3 m away)."""
    angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    lineage = LineageMap(0.05, angles, np.zeros(3), max_range_m=7.99, usable_m=7.98, occ_thresh=0.25)
    ranges = (3.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))).astype(np.float32)
    lineage.sync(np.zeros((1, 3)), [ranges])
    return lineage


def test_the_view_covers_what_was_seen_and_the_robot() -> None:
    view = planning_view(_lineage(), np.array([0.0, 0.0, 0.0]), 0.05)
    g = view.grid
    assert g.resolution_m == 0.05
    assert g.origin_x_m <= -3.0 and g.origin_x_m + g.width * 0.05 >= 3.0
    rc = g.world_to_cell(np.array([[0.0, 0.0], [3.01, 0.0]]))  # the hits at 3 m lie in the cell [3.0, 3.05)
    assert view.image[rc[0, 0], rc[0, 1]] == FREE and view.image[rc[1, 0], rc[1, 1]] == OCCUPIED


@pytest.mark.parametrize("max_cells", [1_000, 10_000])
def test_a_large_map_is_planned_on_coarser_cells(max_cells: int) -> None:
    view = planning_view(_lineage(), np.array([0.0, 0.0, 0.0]), 0.05, max_cells)
    ratio = view.grid.resolution_m / 0.05
    assert ratio > 1 and abs(ratio - round(ratio)) < 1e-9
    assert view.grid.width * view.grid.height <= 1.2 * max_cells


def _corridor_choice() -> tuple[np.ndarray, Viewpoints, object]:
    """A 6 m × 2 m corridor, the robot at x = 2 m: a closet's viewpoint 1 m west (2 m² expected), a hall's two 3 and
    3.5 m east (6 m² each)."""
    grid = GridSpec(0.1, 0.0, 0.0, 60, 20)
    image = np.full(grid.shape, FREE, np.float32)
    image[[0, -1], :] = OCCUPIED
    image[:, [0, -1]] = OCCUPIED
    field = cost_field(image, grid, np.array([2.05, 1.05]), robot_radius_m=0.2, margin_m=0.05)
    cells = np.array([[10, 10], [10, 50], [10, 55]])
    points = Viewpoints(np.arange(3), cells, grid.cell_to_world(cells), field.cost_m[cells[:, 0], cells[:, 1]],
                        np.ones(3, np.int64))
    return np.array([2.0, 6.0, 6.0]), points, field


def test_the_regret_of_leaving_a_closet_behind_makes_it_the_goal() -> None:
    gain, points, field = _corridor_choice()
    ratio = gain / (points.cost_m + 1.0)
    assert int(np.argmax(ratio)) == 1  # gain per metre alone drives to the hall and comes back for the closet
    regret = regret_scores(gain, points, field, 1.0, 12, 1.0)
    assert int(np.argmax(regret)) == 0
    np.testing.assert_allclose(regret[0], ratio[0])  # the tour's best start has no regret
    assert regret[1] < ratio[1]
    assert int(np.argmax(tour_scores(gain, points, field, 1.0, 12))) == 0
    # a viewpoint the samples expect nothing from is no stop of the tour: it scores below every stop
    low = regret_scores(np.array([0.5, 6.0, 6.0]), points, field, 1.0, 12, 1.0)
    assert low[0] < 0 < low[1:].min()
