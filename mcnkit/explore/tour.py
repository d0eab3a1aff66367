"""The order in which to visit frontier viewpoints: the shortest open tour from the robot through all of them.

Greedy exploration (the nearest frontier, or the best gain per metre) decides one goal at a time and so leaves
pieces behind: a small room next to the robot skipped for a larger view farther on costs a trip back at the end.
Planners that plan a tour through every frontier and drive to its first stop avoid those trips (FUEL, Zhou et al.
2021; TARE, Cao et al. 2021).  :func:`open_tour` finds a short open path from the robot through N places: nearest
neighbour, then 2-opt moves (reverse a stretch of the tour) while one shortens it; N is a planning step's handful of
viewpoints, so this takes well under a millisecond per place.

Example:
    >>> open_tour(np.array([1.0, 5.0, 2.0]), np.array([[0, 4, 1], [4, 0, 3], [1, 3, 0]], float)).tolist()
    [0, 2, 1]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["open_tour", "tour_length"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def tour_length(order: I64, from_start_m: F64, between_m: F64) -> float:
    """Length [m] of visiting the places in ``order`` from the start: ``from_start_m`` (N,) start → place,
    ``between_m`` (N, N) place → place."""
    order = np.asarray(order, np.int64)
    if len(order) == 0:
        return 0.0
    return float(from_start_m[order[0]] + between_m[order[:-1], order[1:]].sum())


def open_tour(from_start_m: F64, between_m: F64) -> I64:
    """A short order (N,) in which to visit N places from the start (it need not return): the nearest-neighbour
    tour improved by 2-opt moves until none shortens it."""
    from_start_m = np.asarray(from_start_m, np.float64)
    between_m = np.asarray(between_m, np.float64)
    n = len(from_start_m)
    if n == 0:
        return np.zeros(0, np.int64)
    order = [int(np.argmin(from_start_m))]
    left = set(range(n)) - {order[0]}
    while left:
        rest = np.array(sorted(left))
        nxt = int(rest[np.argmin(between_m[order[-1], rest])])
        order.append(nxt)
        left.remove(nxt)
    tour = np.array(order, np.int64)
    best = tour_length(tour, from_start_m, between_m)
    improved = True
    while improved:
        improved = False
        for i in range(n - 1):
            for j in range(i + 1, n):
                cand = np.concatenate([tour[:i], tour[i : j + 1][::-1], tour[j + 1 :]])
                length = tour_length(cand, from_start_m, between_m)
                if length < best - 1e-9:
                    tour, best, improved = cand, length, True
    return tour
