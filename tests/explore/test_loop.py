"""The closed loop on two small rooms: both planners explore them, deterministically, within the budget; a robot that
touches a wall its lidar does not see goes around it instead of into it again."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.explore.config import ExploreConfig, GainConfig
from mcnkit.explore.loop import Explorer
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
    assert 1 <= ex.n_collisions <= 5 and len(ex.contacts) == ex.n_collisions
    felt = np.array([xy for _, xy in ex.contacts])
    assert np.all(np.abs(felt[:, 0] - 4.05) < 0.35) and np.all((felt[:, 1] > 0.7) & (felt[:, 1] < 2.3))  # at the door
    # without the contacts on its map it tries the door until every goal behind it is given up
    blind = Explorer(rooms, FrontierPlanner(), ExploreConfig(contact_keep_s=0.0), sim=SHORT_SIGHTED, seed=2,
                     low_obstacles=low)
    blind.run()
    assert blind.n_collisions > 20 * ex.n_collisions and blind.path_length_m > 2 * ex.path_length_m
