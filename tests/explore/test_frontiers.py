"""Frontiers and their viewpoints on hand-made maps."""

from __future__ import annotations

import numpy as np

from mcnkit.explore.config import ExploreConfig
from mcnkit.explore.frontiers import find_frontiers, planning_map, viewpoints
from mcnkit.explore.paths import cost_field, traversable_cells
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec

GRID = GridSpec(0.1, 0.0, 0.0, 80, 40)


def _half_known() -> np.ndarray:
    """Cols 0-39 known (free, walled above, below and left), cols 40-79 unknown: one straight 3.8 m frontier."""
    image = np.full(GRID.shape, UNKNOWN, np.float32)
    image[:, :40] = FREE
    image[[0, -1], :40] = OCCUPIED
    image[:, 0] = OCCUPIED
    return image


def test_the_boundary_is_the_frontier_cut_into_segments() -> None:
    f = find_frontiers(_half_known(), GRID, ExploreConfig(segment_m=2.0))
    assert set(f.cells[:, 1]) == {39}
    assert sorted(f.cells[:, 0]) == list(range(1, 39))
    assert f.n_segments == 2  # rows 1-19 and 20-38 (2 m tiles)
    assert f.mask.sum() == 38
    np.testing.assert_allclose(f.xy_m()[:, 0], 3.95)


def test_thin_unknown_and_small_holes_make_no_frontier() -> None:
    image = np.full(GRID.shape, FREE, np.float32)
    image[[0, -1], :] = OCCUPIED
    image[:, [0, -1]] = OCCUPIED
    image[5:35, 20] = UNKNOWN  # a stripe between two beams: one cell wide
    image[10:14, 50:54] = UNKNOWN  # a 0.16 m² hole
    planned = planning_map(image)
    assert (planned[5:35, 20] == FREE).all() and (planned[10:14, 50:54] == UNKNOWN).all()
    cfg = ExploreConfig(unknown_min_m2=0.25)
    assert find_frontiers(planned, GRID, cfg).n_segments == 0
    assert find_frontiers(planned, GRID, ExploreConfig(unknown_min_m2=0.1)).n_segments == 1


def test_viewpoints_are_reachable_nearest_first_and_skip_the_blacklist() -> None:
    image = _half_known()
    cfg = ExploreConfig(segment_m=2.0, reach_m=0.6)
    f = find_frontiers(image, GRID, cfg)
    field = cost_field(image, GRID, np.array([1.05, 0.85]), 0.2, 0.05)
    v = viewpoints(f, field, cfg, np.zeros((0, 2)))
    assert len(v) == 2 and list(v.size) == [19, 19]
    assert np.all(np.diff(v.cost_m) >= 0)
    assert v.segment[0] == f.segment[np.argmin(f.cells[:, 0])]  # the lower segment is nearer the robot
    assert np.all(v.xy_m[:, 0] >= 3.95 - 0.6 - 1e-9) and np.all(np.isfinite(v.cost_m))
    kept = viewpoints(f, field, cfg, v.xy_m[:1])
    assert len(kept) == 1 and kept.segment[0] == v.segment[1]
    walled = image.copy()
    walled[:, 30] = OCCUPIED  # the frontier is now behind a wall
    field = cost_field(walled, GRID, np.array([1.05, 0.85]), 0.2, 0.05)
    assert len(viewpoints(find_frontiers(walled, GRID, cfg), field, cfg, np.zeros((0, 2)))) == 0


def test_a_door_the_map_draws_narrow_is_squeezed_through() -> None:
    """A 0.5 m door (its middle 0.25 m from both jambs): too narrow for radius 0.2 m + 0.05 m margin, wide enough
    for the radius alone."""
    from mcnkit.explore.planners import FrontierPlanner, decide

    grid = GridSpec(0.05, 0.0, 0.0, 80, 40)
    image = np.full(grid.shape, UNKNOWN, np.float32)
    image[:, :60] = FREE
    image[[0, -1], :60] = OCCUPIED
    image[:, 0] = OCCUPIED
    image[:, 30] = OCCUPIED
    image[15:25, 30] = FREE  # rows 15-24: 0.5 m
    view = _View(grid, image, np.array([0.75, 1.0, 0.0]))
    d = decide(view, FrontierPlanner(), ExploreConfig(plan_margin_m=0.05), 0.2, np.zeros((0, 2)))
    assert d.choice is not None and d.path_m is not None and d.path_m[-1][0] > 2.0
    assert d.field.traversable[:, 30].sum() == 2  # the door's two middle cells, 0.25 m from both jambs
    assert not traversable_cells(image, 0.05, 0.2, 0.05)[0][:, 30].any()  # none with the margin


class _View:
    """A planning view without a lineage (the frontier planner needs none)."""

    def __init__(self, grid: GridSpec, image: np.ndarray, pose: np.ndarray) -> None:
        self.grid, self.image, self.pose, self.lineage = grid, image, pose, None


def test_the_goal_is_kept_while_its_frontier_is_there() -> None:
    from mcnkit.explore.planners import FrontierPlanner, decide

    image = _half_known()
    view = _View(GRID, image, np.array([1.05, 0.85, 0.0]))
    fresh = decide(view, FrontierPlanner(), ExploreConfig(segment_m=2.0), 0.2, np.zeros((0, 2)))
    assert fresh.choice == 0 and not fresh.kept  # the nearest
    far = fresh.points.xy_m[1]
    kept = decide(view, FrontierPlanner(), ExploreConfig(segment_m=2.0), 0.2, np.zeros((0, 2)), far + np.array([0.0, 0.5]))
    assert kept.kept and kept.choice == 1 and kept.score[1] < kept.score[0]
    free = decide(view, FrontierPlanner(), ExploreConfig(segment_m=2.0, commit_m=0.0), 0.2, np.zeros((0, 2)), far)
    assert free.choice == 0 and not free.kept
