"""The whole log as one pose graph (mcnkit.slam.wholegraph), on a ring of 2 m corridors round a 36 m × 10 m block:
in its long sides a 10 m scanner sees no end wall, so the scans pin nothing along the axis there."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from mcnkit.geometry import compose, relative
from mcnkit.slam.config import OfflineConfig
from mcnkit.slam.wholegraph import WholeGraphScans, _seen_by, odometry_links, revisit_pairs_by_path, whole_log_graph
from mcnkit.types import LidarSpec
from tests.slam.test_fastslam import LIDAR, _box, cast

RING = np.array(_box(0, 0, 40, 14) + _box(2, 2, 38, 12) + [(14, 0, 14, 0.6), (27, 14, 27, 13.4)])
"""The ring's outer and inner walls, and two door frames (the only features along the long sides)."""


def _ring_path(laps: float = 1.3, step_m: float = 1.0) -> np.ndarray:
    """Round the ring's centre line anticlockwise from (1, 1), ``step_m`` steps, each corner a turn in place in two
    45° steps, for ``laps`` laps."""
    corners = [(1.0, 1.0), (39.0, 1.0), (39.0, 13.0), (1.0, 13.0)]
    poses = [np.array([1.0, 1.0, 0.0])]
    length = 2 * (38 + 12)
    for (x0, y0), (x1, y1) in itertools.pairwise(corners * 3):
        heading = np.arctan2(y1 - y0, x1 - x0)
        while abs(np.angle(np.exp(1j * (heading - poses[-1][2])))) > 1e-9:
            turn = np.clip(np.angle(np.exp(1j * (heading - poses[-1][2]))), -np.pi / 4, np.pi / 4)
            poses.append(poses[-1] + [0, 0, turn])
        n = int(round(np.hypot(x1 - x0, y1 - y0) / step_m))
        for k in range(1, n + 1):
            poses.append(np.array([x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, heading]))
            if len(poses) > laps * length / step_m:
                return np.array(poses)
    return np.array(poses)


def _chain(start: np.ndarray, steps: np.ndarray) -> np.ndarray:
    out = [start]
    for z in steps:
        out.append(compose(out[-1], z))
    return np.array(out)


def _steps(poses: np.ndarray) -> np.ndarray:
    return relative(poses[:-1], poses[1:])


def _ate(poses: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((poses[:, :2] - truth[:, :2]) ** 2, axis=1))))


@pytest.fixture(scope="module")
def ring() -> tuple[np.ndarray, WholeGraphScans]:
    """The true path and its scans (10 m range, 1 cm noise)."""
    rng = np.random.default_rng(3)
    truth = _ring_path()
    ranges = [cast(p, rng, walls=RING) for p in truth]
    return truth, WholeGraphScans(ranges, LIDAR.angles_rad, np.zeros(3), 10.0)


def test_a_loop_bent_by_a_heading_drift_is_pulled_straight_by_the_scans(ring: tuple) -> None:
    truth, scans = ring
    rng = np.random.default_rng(4)
    steps = _steps(truth)
    drift = steps + np.column_stack([rng.normal(0, 0.01, len(steps)), rng.normal(0, 0.01, len(steps)),
                                     0.01 * np.hypot(steps[:, 0], steps[:, 1])])  # 0.6° per metre to the left
    bent = _chain(truth[0], drift)  # the run and its odometry both drift: only the scans can straighten them
    solved, stats = whole_log_graph(bent, scans, bent, np.ones(len(truth) - 1, bool), OfflineConfig())
    assert _ate(bent, truth) > 2.0
    assert _ate(solved, truth) < 0.15
    assert stats.revisit_edges > 10 and stats.odometry_edges == len(truth) - 1 and stats.passes == 2


def test_along_a_corridor_the_odometry_holds_the_length_the_scans_leave_free(ring: tuple) -> None:
    truth, scans = ring
    rng = np.random.default_rng(5)
    steps = _steps(truth)
    short = steps * np.array([0.97, 1.0, 1.0])  # the run's steps 3 % short
    odom = _chain(truth[0], steps + np.column_stack([rng.normal(0, 0.005, (len(steps), 2)), np.zeros(len(steps))]))
    run = _chain(truth[0], short)
    first_lap = slice(0, 105)  # before the second pass's revisits say anything
    solved, _ = whole_log_graph(run[first_lap], WholeGraphScans(scans.ranges_m[first_lap], scans.angles_rad,
                                                                 scans.base_to_laser, scans.max_range_m),
                                odom[first_lap], np.ones(104, bool), OfflineConfig())
    length = lambda p: float(np.hypot(*np.diff(p[:, :2], axis=0).T).sum())  # noqa: E731
    assert length(run[first_lap]) < 0.975 * length(truth[first_lap])
    assert abs(length(solved) / length(truth[first_lap]) - 1) < 0.01  # a third of the run's shortfall at most
    assert _ate(solved, truth[first_lap]) < 0.15


def test_without_odometry_the_revisits_alone_close_the_loop(ring: tuple) -> None:
    truth, scans = ring
    steps = _steps(truth)
    bent = _chain(truth[0], steps + np.column_stack([np.zeros((len(steps), 2)),
                                                     0.01 * np.hypot(steps[:, 0], steps[:, 1])]))
    solved, stats = whole_log_graph(bent, scans, np.zeros_like(bent), np.zeros(len(truth) - 1, bool), OfflineConfig())
    assert stats.odometry_edges == 0 and stats.filter_step_edges == len(truth) - 1
    assert _ate(solved, truth) < 0.25 * _ate(bent, truth)


def test_started_at_the_truth_it_stays_there(ring: tuple) -> None:
    truth, scans = ring
    rng = np.random.default_rng(9)
    steps = _steps(truth)
    odom = _chain(truth[0], steps + np.column_stack([rng.normal(0, 0.01, (len(steps), 2)),
                                                     rng.normal(0, 0.003, len(steps))]))
    with_odometry, _ = whole_log_graph(truth, scans, odom, np.ones(len(truth) - 1, bool), OfflineConfig())
    lidar_only, _ = whole_log_graph(truth, scans, odom, np.zeros(len(truth) - 1, bool), OfflineConfig())
    assert _ate(with_odometry, truth) < 0.05 and _ate(lidar_only, truth) < 0.05


def test_a_return_counts_as_seen_only_where_the_other_scan_looked_as_far() -> None:
    spec = LidarSpec(-np.pi / 2, np.pi / 180, 181, 0.05, 10.0)
    ranges = np.full(181, np.inf, np.float32)
    ranges[:90] = 5.0  # a wall 5 m away on the right half, nothing on the left
    scans = WholeGraphScans([ranges], spec.angles_rad, np.zeros(3), 10.0)
    bearing = np.radians([-45.0, -45.0, 60.0, -1.0])  # beams 45, 45, 150 and 89
    dist = np.array([4.0, 6.0, 3.0, 4.0])
    points = np.column_stack([dist * np.cos(bearing), dist * np.sin(bearing)])
    seen = _seen_by(scans, 0, points, margin_m=0.3)
    # before the wall: seen; behind it: hidden; where no beam returned: not seen; at the edge of what it saw: not
    assert seen.tolist() == [True, False, False, False]


def test_revisits_pair_two_passes_of_one_place_and_nothing_within_one_pass() -> None:
    t = np.linspace(0, 4 * np.pi, 200, endpoint=False)  # two laps of a 5 m circle
    poses = np.column_stack([5 * np.cos(t), 5 * np.sin(t), t + np.pi / 2])
    path = 5 * t
    pairs = revisit_pairs_by_path(poses, path, distance_m=1.0, turn_rad=1.0, min_path_m=10.0, bin_nodes=2)
    assert len(pairs) > 0
    assert np.all(path[pairs[:, 1]] - path[pairs[:, 0]] > 25)  # a lap apart, never neighbours of one lap
    assert np.all(np.hypot(*(poses[pairs[:, 0], :2] - poses[pairs[:, 1], :2]).T) < 1.0)
    assert len(np.unique(pairs // 2, axis=0)) == len(pairs)  # one pair per 2 × 2 block


def test_odometry_links_say_where_the_odometry_gave_every_step_between_two_nodes():
    gave = np.array([False, True, True, False, True, True])  # scan 3's motion came from the scans alone
    assert odometry_links(np.array([0, 2, 4, 5]), gave).tolist() == [True, False, True]
