"""The planning view: the best particle's map pooled for planning, coarser in a large building."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.explore.planners import planning_view
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import FREE, OCCUPIED


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
