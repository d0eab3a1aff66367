"""The planning view: the best particle's map pooled for planning, coarser in a large building; scores that see the
whole tour."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.explore.config import ExploreConfig, GainConfig
from mcnkit.explore.frontiers import Viewpoints
from mcnkit.explore.paths import cost_field
from mcnkit.explore.planners import (
    McnPlanner,
    PlanningView,
    decide,
    local_first,
    nearest_worth,
    planning_view,
    regret_scores,
    tour_scores,
)
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec


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


def test_what_lies_beside_the_robot_goes_first_with_local_first() -> None:
    gain, points, _ = _corridor_choice()
    ratio = gain / (points.cost_m + 1.0)
    local = local_first(ratio, gain, points.cost_m, local_m=1.5, min_gain_m2=1.0)
    assert int(np.argmax(local)) == 0  # the closet 1 m away, before the larger hall 3 m away
    np.testing.assert_array_equal(np.argsort(local[1:]), np.argsort(ratio[1:]))  # the rest keep their order
    # a near viewpoint the samples expect too little from, or a radius that takes in everything, changes nothing
    np.testing.assert_array_equal(local_first(ratio, gain, points.cost_m, 1.5, 3.0), ratio)
    np.testing.assert_array_equal(local_first(ratio, gain, points.cost_m, 100.0, 1.0), ratio)


def test_nearest_worth_goes_to_the_nearest_viewpoint_that_hides_enough() -> None:
    gain, points, _ = _corridor_choice()
    assert int(np.argmax(nearest_worth(gain, points.cost_m, 1.0))) == 0  # the closet beside the robot first
    # a closet the samples expect too little from is left for last: the nearest of the others goes first
    score = nearest_worth(np.array([0.5, 6.0, 6.0]), points.cost_m, 1.0)
    assert int(np.argmax(score)) == 1 and score[0] < score[2]
    # none worth it: the nearest of all, as the frontier planner
    np.testing.assert_array_equal(nearest_worth(np.zeros(3), points.cost_m, 1.0), -points.cost_m)


class _Fixed:
    """A planner whose scores are fixed: 1.2 for the cheapest viewpoint, 1.0 for the others."""

    name = "fixed"
    commits = False

    def __init__(self, keep_bonus: float, gain_m2: float = 0.0) -> None:
        self.keep_bonus = keep_bonus
        self.gain_m2 = gain_m2

    def score(self, view: PlanningView, points: Viewpoints, field: object) -> tuple[np.ndarray, np.ndarray, None]:
        s = np.ones(len(points))
        s[0] = 1.2
        return np.full(len(points), self.gain_m2), s, None


def _half_known_view() -> PlanningView:
    """A 6 m × 4 m hall, its west half known free, its east half unknown: a 4 m frontier down the middle."""
    grid = GridSpec(0.05, 0.0, 0.0, 120, 80)
    image = np.full(grid.shape, UNKNOWN, np.float32)
    image[:, :60] = FREE
    image[[0, -1], :] = OCCUPIED
    image[:, [0, -1]] = OCCUPIED
    return PlanningView(grid, image, np.array([1.0, 2.0, 0.0]), _lineage())


@pytest.mark.parametrize(("bonus", "kept"), [(0.25, True), (0.1, False)])
def test_a_goal_is_kept_unless_another_scores_the_keep_bonus_more(bonus: float, kept: bool) -> None:
    view = _half_known_view()
    first = decide(view, _Fixed(bonus), ExploreConfig(), 0.2, np.zeros((0, 2)))
    assert first.choice == 0 and len(first.points) >= 2 and not first.kept
    goal = first.points.xy_m[1]  # the robot is driving to the viewpoint that now scores 1.0 against 1.2
    again = decide(view, _Fixed(bonus), ExploreConfig(), 0.2, np.zeros((0, 2)), goal)
    assert again.kept is kept and again.choice == (1 if kept else 0)


def test_same_noise_draws_the_same_samples_for_the_same_map() -> None:
    net = UNet(UNetConfig(base_channels=4, depth=2, dropout=0.5, size=64)).eval()
    view = planning_view(_lineage(), np.array([0.0, 0.0, 0.0]), 0.05)
    points = Viewpoints(np.zeros(0, np.int64), np.zeros((0, 2), np.int64), np.zeros((0, 2)), np.zeros(0),
                        np.zeros(0, np.int64))
    field = cost_field(view.image, view.grid, view.pose[:2], 0.2, 0.05)

    def two_draws(same: bool) -> tuple[np.ndarray, np.ndarray]:
        planner = McnPlanner(net, GainConfig(samples=3, same_noise=same), 8.0, torch.Generator().manual_seed(0))
        a, b = (planner.score(view, points, field)[2] for _ in range(2))
        assert a is not None and b is not None
        return a.samples, b.samples

    np.testing.assert_array_equal(*two_draws(True))
    assert not np.array_equal(*two_draws(False))


def test_sample_share_mixes_the_samples_gain_with_the_maps_own() -> None:
    net = UNet(UNetConfig(base_channels=4, depth=2, dropout=0.5, size=64)).eval()
    angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    lineage = LineageMap(0.05, angles, np.zeros(3), max_range_m=7.99, usable_m=7.98, occ_thresh=0.25)
    ranges = (3.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))).astype(np.float32)
    ranges[np.abs(angles) < 0.1] = 6.0  # a door east: a passage seen 6 m out, unknown space on both sides of it
    lineage.sync(np.zeros((1, 3)), [ranges])
    view = planning_view(lineage, np.zeros(3), 0.05)
    field = cost_field(view.image, view.grid, view.pose[:2], 0.2, 0.05)
    cells = view.grid.world_to_cell(np.array([[0.0, 0.0], [4.0, 0.0]]))
    points = Viewpoints(np.arange(2), cells, view.grid.cell_to_world(cells), field.cost_m[cells[:, 0], cells[:, 1]],
                        np.ones(2, np.int64))

    def gain(**kw: object) -> np.ndarray:
        config = GainConfig(samples=3, same_noise=True, **kw)  # type: ignore[arg-type]
        return McnPlanner(net, config, 8.0, torch.Generator().manual_seed(0)).score(view, points, field)[0]

    samples_only, plain = gain(), gain(gain="observed")
    assert plain[1] > 0  # from the passage the map's own walls leave unknown space in sight
    np.testing.assert_allclose(gain(sample_share=0.0), plain)
    np.testing.assert_allclose(gain(sample_share=0.5), 0.5 * samples_only + 0.5 * plain)


@pytest.mark.parametrize(("release", "gain_m2", "kept"), [(False, 0.0, True), (True, 0.0, False), (True, 2.0, True)])
def test_a_returned_goal_is_let_go_once_nothing_is_expected_there(release: bool, gain_m2: float, kept: bool) -> None:
    view = _half_known_view()
    config = ExploreConfig(release_empty=release)
    goal = decide(view, _Fixed(0.0, gain_m2), config, 0.2, np.zeros((0, 2))).points.xy_m[1]
    # the robot came back to this goal (keep_goal): kept against a better score, unless it promises nothing any more
    again = decide(view, _Fixed(0.0, gain_m2), config, 0.2, np.zeros((0, 2)), goal, keep_goal=True)
    assert again.kept is kept and again.choice == (1 if kept else 0)


def test_the_gains_are_computed_on_whatever_completion_prediction_gives() -> None:
    from mcnkit.explore.predict import Prediction, choose_window

    angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    lineage = LineageMap(0.05, angles, np.zeros(3), max_range_m=7.99, usable_m=7.98, occ_thresh=0.25)
    ranges = (3.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))).astype(np.float32)
    ranges[np.abs(angles) < 0.1] = 6.0  # a door east: unknown space beside the passage
    lineage.sync(np.zeros((1, 3)), [ranges])
    view = planning_view(lineage, np.zeros(3), 0.05)
    field = cost_field(view.image, view.grid, view.pose[:2], 0.2, 0.05)
    cells = view.grid.world_to_cell(np.array([[4.0, 0.0]]))
    points = Viewpoints(np.arange(1), cells, view.grid.cell_to_world(cells), field.cost_m[cells[:, 0], cells[:, 1]],
                        np.ones(1, np.int64))

    class Given(McnPlanner):
        """A planner whose completion is fixed (as the benchmark's perfect predictor gives the true plan)."""

        def __init__(self, fill: float) -> None:
            super().__init__(None, GainConfig(gain="free"), 8.0, torch.Generator())  # type: ignore[arg-type]
            self.fill = fill

        def prediction(self, view: PlanningView) -> Prediction:
            window = choose_window(view.lineage.seen_bounds_m(), self.config, 64, 0.05, view.pose[:2])
            partial = view.lineage.pooled(window).astype(np.float32)
            return Prediction(window, partial, np.where(partial == UNKNOWN, self.fill, partial)[None])

    walled, open_ = (Given(fill).score(view, points, field)[0][0] for fill in (OCCUPIED, FREE))
    assert walled == 0.0 < open_  # nothing to see where the completion walls the unknown off; floor where it is open


def test_beyond_reach_counts_what_a_scan_from_the_maps_edge_sees_past_the_window() -> None:
    from mcnkit.explore.predict import Prediction, choose_window

    angles = np.linspace(-np.pi, np.pi, 360, endpoint=False)
    lineage = LineageMap(0.05, angles, np.zeros(3), max_range_m=7.99, usable_m=7.98, occ_thresh=0.25)
    ranges = (3.0 / np.maximum(np.abs(np.cos(angles)), np.abs(np.sin(angles)))).astype(np.float32)
    ranges[np.abs(angles) < 0.1] = 6.0  # a door east, its passage seen 6 m out: the seen map ends there
    lineage.sync(np.zeros((1, 3)), [ranges])
    view = planning_view(lineage, np.zeros(3), 0.05)
    field = cost_field(view.image, view.grid, view.pose[:2], 0.2, 0.05)
    cells = view.grid.world_to_cell(np.array([[5.5, 0.0], [-2.0, 0.0]]))  # at the passage's end; in the room
    points = Viewpoints(np.arange(2), cells, view.grid.cell_to_world(cells), field.cost_m[cells[:, 0], cells[:, 1]],
                        np.ones(2, np.int64))

    class Given(McnPlanner):
        """Completions that fill the unknown with ``fill`` (free: open house all around; occupied: none)."""

        def __init__(self, fill: float, beyond_reach: bool) -> None:
            super().__init__(None, GainConfig(beyond_reach=beyond_reach), 8.0, torch.Generator())  # type: ignore[arg-type]
            self.fill = fill

        def prediction(self, view: PlanningView) -> Prediction:
            window = choose_window(view.lineage.seen_bounds_m(), self.config, 64, 0.05, view.pose[:2])
            partial = view.lineage.pooled(window).astype(np.float32)
            return Prediction(window, partial, np.where(partial == UNKNOWN, self.fill, partial)[None])

    window_only, reach = (Given(FREE, on).score(view, points, field)[0] for on in (False, True))
    # The window ends 2 m past the seen map, a scan from its edge reaches 8 m: the rest counts with beyond_reach ...
    assert reach[0] > window_only[0] > 0
    # ... not from inside the room, whose known walls hide everything past the window ...
    assert reach[1] == pytest.approx(window_only[1])
    # ... and less where the samples wall the unknown off (they expect less of it in sight inside the window).
    walled = [Given(OCCUPIED, on).score(view, points, field)[0][0] for on in (False, True)]
    assert 0 <= walled[1] - walled[0] < reach[0] - window_only[0]
