"""The visiting order of frontier viewpoints: the shortest open tour from the robot, and the scores it gives."""

from __future__ import annotations

import itertools

import numpy as np

from mcnkit.explore.tour import open_tour, tour_length


def test_a_small_room_beside_the_robot_is_visited_before_the_far_hall() -> None:
    # places on a line: a closet 1 m east of the robot, a hall 5 m and 7 m west
    x = np.array([1.0, -5.0, -7.0])
    order = open_tour(np.abs(x), np.abs(x[:, None] - x[None, :]))
    assert order.tolist() == [0, 1, 2]  # 1 + 6 + 2 = 9 m; the hall first would be 5 + 2 + 8 = 15 m
    assert tour_length(order, np.abs(x), np.abs(x[:, None] - x[None, :])) == 9.0


def test_the_tour_is_as_short_as_the_best_order_on_random_places() -> None:
    rng = np.random.default_rng(4)
    for _ in range(20):
        xy = rng.uniform(0, 10, (7, 2))
        robot = rng.uniform(0, 10, 2)
        start = np.hypot(*(xy - robot).T)
        between = np.hypot(*(xy[:, None] - xy[None, :]).transpose(2, 0, 1))
        best = min(tour_length(np.array(p), start, between) for p in itertools.permutations(range(7)))
        order = open_tour(start, between)
        assert sorted(order.tolist()) == list(range(7))
        assert tour_length(order, start, between) <= 1.1 * best  # 2-opt: within a tenth of the optimum


def test_no_places_no_tour() -> None:
    assert open_tour(np.zeros(0), np.zeros((0, 0))).shape == (0,)
    assert open_tour(np.array([3.0]), np.zeros((1, 1))).tolist() == [0]
