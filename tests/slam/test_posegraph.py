"""The pose graph: a loop of drifting steps is pulled shut by one loop edge; a degenerate loop edge (no
information along an axis) moves nothing along it."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.geometry import compose, relative
from mcnkit.slam.posegraph import Edges, edge_errors, optimize


def _circle(k: int = 200, radius: float = 10.0) -> np.ndarray:
    th = np.linspace(0, 2 * np.pi, k, endpoint=False)
    return np.c_[radius * np.cos(th), radius * np.sin(th), th + np.pi / 2]


def _chain(start: np.ndarray, steps: np.ndarray) -> np.ndarray:
    out = [start]
    for d in steps:
        out.append(compose(out[-1], d))
    return np.array(out)


def test_one_loop_edge_closes_a_drifting_loop() -> None:
    truth = _circle()
    steps = relative(truth[:-1], truth[1:])
    biased = steps + np.array([0.0, 0.0, 0.002])  # a heading bias: dead reckoning ends far off
    start = _chain(truth[0], biased)
    assert np.hypot(*(start[-1, :2] - truth[-1, :2])) > 1.0
    seq = Edges(np.arange(len(truth) - 1), np.arange(1, len(truth)), biased,
                np.broadcast_to(np.diag([1e4, 1e4, 1e4]), (len(truth) - 1, 3, 3)).copy(), np.zeros(len(truth) - 1, bool))
    loop = Edges.of([(len(truth) - 1, 0, relative(truth[-1], truth[0]))], np.diag([1e4, 1e4, 1e5]), robust=True)
    solved = optimize(start, Edges.concat([seq, loop]), huber=1e9)
    assert np.abs(edge_errors(solved, loop)).max() < 0.01
    assert np.hypot(*(solved[:, :2] - truth[:, :2]).T).max() < 0.2


def test_a_loop_edge_without_information_along_x_leaves_x_alone() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    seq = Edges.of([(0, 1, [1.0, 0, 0]), (1, 2, [1.0, 0, 0])], np.diag([100.0, 100.0, 100.0]))
    info = np.zeros((1, 3, 3))
    info[0] = np.diag([0.0, 1e4, 1e4])  # a corridor along x: the match says nothing about x
    wrong_along = Edges(np.array([0]), np.array([2]), np.array([[2.7, 0.0, 0.0]]), info, np.array([True]))
    solved = optimize(poses, Edges.concat([seq, wrong_along]), huber=1e9)
    assert solved[2, 0] == pytest.approx(2.0, abs=1e-6)


def test_edges_must_name_existing_nodes() -> None:
    with pytest.raises(ValueError, match="outside"):
        optimize(np.zeros((2, 3)), Edges.of([(0, 5, [1, 0, 0])], np.eye(3)))
