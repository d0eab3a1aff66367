"""The closed loop on two small rooms: both planners explore them, deterministically, within the budget; a robot that
touches a wall its lidar does not see goes around it instead of into it again."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.explore.config import ExploreConfig, GainConfig
from mcnkit.explore.loop import Explorer
from mcnkit.explore.metrics import summarize
from mcnkit.explore.planners import FrontierPlanner, McnPlanner
from mcnkit.sim import LidarConfig, PlanRaster, SimConfig

SHORT_SIGHTED = SimConfig(lidar=LidarConfig(range_max_m=3.0))
"""A 3 m lidar: the second room is not seen from the first."""


def test_the_frontier_planner_explores_both_rooms(rooms: PlanRaster) -> None:
    ex = Explorer(rooms, FrontierPlanner(), sim=SHORT_SIGHTED, seed=3)
    records = ex.run()
    assert ex.stop_reason in ("explored", "coverage")  # no frontier left, or everything seen
    assert ex.coverage > 0.97 and records[-1].coverage == ex.coverage
    assert ex.n_collisions == 0
    truth = np.array([r.truth for r in records])
    assert (truth[:, 0] > 4.1).any() and (truth[:, 0] < 4.0).any()  # it went through the door
    np.testing.assert_allclose(records[-1].path_length_m, np.hypot(*np.diff(truth[:, :2], axis=0).T).sum())
    estimate = np.array([r.estimate for r in records])
    assert np.hypot(*(estimate - truth)[:, :2].T).max() < 0.2
    assert all(p.cpu_s > 0 for p in ex.plans) and ex.plans[0].frame == 0
    assert all(r.decision is None for r in records)  # the kept records hold no maps: only the last decision does
    assert [r.index for r in records[:-1]] == list(range(len(records) - 1))
    assert np.all(np.diff([r.coverage for r in records]) >= 0)


def test_same_seed_same_run_and_the_budget_stops_it(rooms: PlanRaster) -> None:
    cfg = ExploreConfig(budget_m=2.0)
    a = Explorer(rooms, FrontierPlanner(), cfg, seed=5)
    b = Explorer(rooms, FrontierPlanner(), cfg, seed=5)
    ra, rb = a.run(), b.run()
    assert a.stop_reason == "budget" and 2.0 <= a.path_length_m < 2.1
    np.testing.assert_array_equal([r.truth for r in ra], [r.truth for r in rb])
    other = Explorer(rooms, FrontierPlanner(), cfg, seed=6)
    assert not np.array_equal(other.truth, ra[0].truth)


def test_the_mcn_planner_scores_viewpoints_from_samples(rooms: PlanRaster) -> None:
    net = UNet(UNetConfig(base_channels=4, depth=2, dropout=0.5, size=64)).eval()
    gain = GainConfig(samples=3, beams=90)
    ex = Explorer(rooms, McnPlanner(net, gain, 8.0, torch.Generator().manual_seed(0)),
                  ExploreConfig(budget_m=6.0), seed=3)
    d = ex.step().decision
    ex.run()
    assert ex.stop_reason in ("budget", "explored", "coverage")
    assert d is not None and ex.last_decision is not None and ex.plans[-1].cpu_s == ex.last_decision.cpu_s
    assert d.prediction is not None and d.prediction.samples.shape == (3, 64, 64)
    assert len(d.gain) == len(d.score) == len(d.points) > 0
    assert np.all(d.gain >= 0) and np.all(np.isfinite(d.score))
    assert d.choice == int(np.argmax(d.score))


def test_the_tour_trade_off_drives_to_the_first_stop_of_a_tour(rooms: PlanRaster) -> None:
    net = UNet(UNetConfig(base_channels=4, depth=2, dropout=0.5, size=64)).eval()
    gain = GainConfig(samples=2, beams=90, tradeoff="tour", tour_min_gain_m2=0.0)
    ex = Explorer(rooms, McnPlanner(net, gain, 8.0, torch.Generator().manual_seed(0)), sim=SHORT_SIGHTED, seed=3)
    steps = [d for d in (ex.step().decision for _ in range(400)) if d is not None and d.choice is not None]
    ex.run()
    assert ex.stop_reason in ("explored", "coverage") and ex.coverage > 0.97
    for d in steps:
        n = min(len(d.points), gain.tour_places)
        assert sorted(d.score)[-n:] == list(range(1, n + 1))  # the tour's stops ranked 1..n, the first scores n
        assert d.choice == int(np.argmax(d.score))


def test_stop_coverage(rooms: PlanRaster) -> None:
    ex = Explorer(rooms, FrontierPlanner(), ExploreConfig(stop_coverage=0.5), seed=3)
    ex.run()
    assert ex.stop_reason == "coverage" and 0.5 <= ex.coverage < 0.97
    with pytest.raises(ValueError, match="stop_coverage"):
        ExploreConfig(stop_coverage=0.0)


def test_a_wall_felt_but_not_seen_is_planned_around_not_driven_into(rooms: PlanRaster) -> None:
    # the door between the rooms is barred below the lidar's plane: the robot sees the other room but cannot enter it
    low = np.zeros_like(rooms.free)
    low[38:62, 99:103] = True
    ex = Explorer(rooms, FrontierPlanner(), sim=SHORT_SIGHTED, seed=2, low_obstacles=low)
    ex.run()
    start_x = ex.records[0].truth[0]
    assert start_x > 4.1 and all(r.truth[0] > 4.1 for r in ex.records)  # it stayed in its room
    assert ex.stop_reason == "explored"  # the far room's frontiers are out of reach once the bar is on the map
    assert summarize(ex).frontiers_left >= 1  # and the summary counts them: explored, not everything seen
    assert 1 <= ex.n_collisions <= 5 and len(ex.contacts) == ex.n_collisions
    felt = np.array([xy for _, xy in ex.contacts])
    assert np.all(np.abs(felt[:, 0] - 4.05) < 0.35) and np.all((felt[:, 1] > 0.7) & (felt[:, 1] < 2.3))  # at the door
    # without the contacts on its map it tries the door until every goal behind it is given up
    blind = Explorer(rooms, FrontierPlanner(), ExploreConfig(contact_keep_s=0.0), sim=SHORT_SIGHTED, seed=2,
                     low_obstacles=low)
    blind.run()
    assert blind.n_collisions > 20 * ex.n_collisions and blind.path_length_m > 2 * ex.path_length_m


def dead_end(width_m: float, length_m: float = 4.0, cell_m: float = 0.05) -> PlanRaster:
    """A corridor ``width_m`` wide along x in [0, ``length_m``) m, walled at both ends, with 1 m of wall around."""
    from mcnkit.types import GridSpec

    n, wall = round(length_m / cell_m), round(1.0 / cell_m)
    grid = GridSpec(cell_m, -1.0, -1.0, n + 2 * wall, round(width_m / cell_m) + 2 * wall)
    free = np.zeros(grid.shape, bool)
    free[wall:-wall, wall:-wall] = True
    return PlanRaster("dead-end", free, grid, np.zeros((0, 2)))


class FickleEastWest:
    """Scores the easternmost viewpoint best at one planning step and the westernmost at the next, as two far goals
    of about equal worth whose scores the samples' noise swaps."""

    name = "fickle"
    commits = False
    keep_bonus = 0.0

    def __init__(self) -> None:
        self.calls = 0

    def score(self, view, points, field):  # type: ignore[no-untyped-def]
        self.calls += 1
        x = points.xy_m[:, 0]
        return np.zeros(len(points)), (x if self.calls % 2 else -x), None


def test_a_goal_chosen_again_after_turning_away_from_it_is_kept_until_reached() -> None:
    corridor = dead_end(1.5, length_m=16.0)  # the 3 m lidar sees a frontier down the corridor either way

    def run(keep: bool) -> Explorer:
        ex = Explorer(corridor, FickleEastWest(), ExploreConfig(budget_m=12.0, keep_returned=keep),
                      sim=SHORT_SIGHTED, seed=3)
        ex.run()
        return ex

    fickle, kept = run(False), run(True)
    east = np.array([p.goal_xy_m[0] > fickle.records[0].truth[0] for p in fickle.plans[:8]])
    assert np.all(east[1:] != east[:-1])  # without the rule it turns back at every planning step
    assert fickle.stop_reason == "budget"
    goals = np.array([p.goal_xy_m for p in kept.plans[:6]])
    assert np.hypot(*(goals[3] - goals[2])) < 0.3  # the first goal, chosen again, is kept over the next step
    assert kept.coverage > fickle.coverage + 0.15  # 0.73 against 0.47 of the corridor


@pytest.mark.parametrize(("heading", "expect"), [(np.pi, "reverses"), (0.0, "creeps forward")])
def test_a_bumper_recovery_moves_the_robot_away_from_the_wall_it_touched(heading: float, expect: str) -> None:
    ex = Explorer(dead_end(0.7, cell_m=0.01), FrontierPlanner(), seed=0)  # cells finer than a frame's move
    ex.truth = np.array([0.205, 0.35, heading])  # its disc (0.2 m) just clear of the closed end
    pose = ex._back_off()
    assert pose[0] > 0.205  # farther from the end wall, facing it (reversing) or facing away from it (forward)
    if expect == "reverses":
        assert abs(np.angle(np.exp(1j * (pose[2] - heading)))) < 1e-9  # straight back


def test_a_robot_wedged_across_a_narrow_corridor_turns_in_place() -> None:
    plan = dead_end(2.0, cell_m=0.01)
    plan.free[145:300, 100:400] = False  # the first 3 m are 0.45 m wide, the last metre 2 m
    ex = Explorer(plan, FrontierPlanner(), seed=0)
    ex.truth = np.array([1.5, 0.225, np.pi / 2])  # across the narrow part: every move brings a wall closer
    pose = ex._back_off()
    np.testing.assert_allclose(pose[:2], ex.truth[:2])
    assert pose[2] != pytest.approx(np.pi / 2)


def test_progress_to_a_goal_is_measured_along_the_path_not_as_the_crow_flies(rooms: PlanRaster) -> None:
    from mcnkit.explore.loop import _Goal

    ex = Explorer(rooms, FrontierPlanner(), seed=3)
    ex._goal = _Goal(np.array([3.0, 0.0]), np.inf)
    ex._path = np.array([[0.0, 0.0], [0.0, 3.0], [3.0, 3.0], [3.0, 0.0]])  # around a wall between robot and goal
    ex._carrot = 1
    ex.estimate = np.array([0.0, 0.5, 0.0])
    assert ex._to_goal_m() == pytest.approx(2.5 + 3.0 + 3.0)  # 3.04 m straight, which driving up the path lengthens
    ex._path = None  # no path (after a collision): straight
    assert ex._to_goal_m() == pytest.approx(np.hypot(3.0, 0.5))


def test_the_robot_starts_where_it_is_told_and_nowhere_it_does_not_fit(rooms: PlanRaster) -> None:
    """``--explore.start-m X Y [YAW_DEG]``: a user's robot enters their building where they say."""
    ex = Explorer(rooms, FrontierPlanner(), ExploreConfig(start_m=(6.0, 1.5, 90.0)), seed=3)
    assert np.allclose(ex.truth, [6.0, 1.5, np.pi / 2]) and ex.reachable.any()
    free_start = Explorer(rooms, FrontierPlanner(), ExploreConfig(start_m=(1.0, 2.0)), seed=3)
    drawn = Explorer(rooms, FrontierPlanner(), seed=3)
    assert np.allclose(free_start.truth[:2], [1.0, 2.0]) and free_start.truth[2] == drawn.truth[2]  # heading drawn
    with pytest.raises(ValueError, match=r"does not fit at \(4.05, 0.5\) m; the nearest place it fits is"):
        Explorer(rooms, FrontierPlanner(), ExploreConfig(start_m=(4.05, 0.5)), seed=3)  # in the wall between rooms
    with pytest.raises(ValueError, match="start_m takes X Y or X Y YAW_DEG"):
        ExploreConfig(start_m=(1.0,))
