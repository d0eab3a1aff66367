"""The robot's own returns: standoffs around the scanner are dropped, the world's returns are kept, and a filter
fed them draws no trail of obstacles along its path and stays closer to it."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.config import MatchingConfig
from mcnkit.slam.selfhits import SelfHits
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan
from tests.slam.test_fastslam import cast, drifting_odometry, true_path

RPLIDAR = LidarSpec(-np.pi, 2 * np.pi / 720, 720, 0.15, 12.0)
"""A 360° scanner, as on a TurtleBot 4."""
OWN_BEAMS = np.r_[85:95, 265:275, 445:455, 625:635, 350:372]
"""Its beams that hit the robot: four standoffs (10 beams each) and a camera mount behind it (22 beams)."""


def with_own_body(ranges: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    r = ranges.copy()
    r[OWN_BEAMS] = 0.16 + rng.normal(0, 0.003, len(OWN_BEAMS))
    return r


def test_a_standoff_is_dropped_once_the_robot_has_turned_in_place_and_the_world_is_kept() -> None:
    """Beams: a standoff (0.14 m), a wall the robot drives along at its planner's clearance (0.28 m), a door frame
    passed in half a metre, a beam that sees past a standoff's edge every other scan, and the room.  The robot drives
    3 m at 0.1 m per scan, turns 1.6 rad in place at 0.1 rad per scan, and drives on."""
    hits = SelfHits(reach_m=0.3, tolerance_m=0.05)
    rng = np.random.default_rng(0)
    for k in range(60):
        turning = 30 <= k < 46
        wall = 0.28 + rng.normal(0, 0.003) if k < 30 else 3.0
        door = 0.25 if 50 <= k < 55 else 4.0
        ranges = np.array([0.14 + rng.normal(0, 0.003), wall, door, 0.14 if k % 2 else 3.0, 2.0 + 0.01 * k], np.float32)
        out = hits.filter(ranges, moved_m=0.0 if turning else 0.1, turned_rad=0.1 if turning else 0.0)
        assert np.isnan(out[0]) == (k >= 45)  # the standoff, once it kept its range through a quarter turn in place
        assert np.array_equal(out[1:], ranges[1:])  # the wall, the door frame, the broken runs, the room: the world's
    assert list(hits.beams) == [0]
    for k in range(3):  # later, the beam sees something near that moves: it was the world's after all
        hits.filter(np.array([0.25 - 0.02 * k, 3.0, 4.0, 3.0, 2.0], np.float32), moved_m=0.1)
    assert list(hits.beams) == [] and list(hits.released) == [0]


def test_a_return_that_keeps_its_range_while_the_robot_turns_in_place_is_its_own() -> None:
    hits = SelfHits(reach_m=0.3, tolerance_m=0.05)
    out = [hits.filter(np.array([0.2, 1.0], np.float32), turned_rad=0.1)[0] for _ in range(20)]
    assert not np.isnan(out[:16]).any() and np.isnan(out[16:]).all()  # a quarter turn (1.6 rad) by scan 16
    # rounding a corner at the return's range (0.02 m along an arc of 0.2 m radius per 0.1 rad) is no turn in place
    rounding = SelfHits(reach_m=0.3, tolerance_m=0.05)
    assert not any(np.isnan(rounding.filter(np.array([0.2], np.float32), moved_m=0.02, turned_rad=0.1)[0])
                   for _ in range(40))
    assert SelfHits(reach_m=0.0, tolerance_m=0.05).filter(np.array([0.1], np.float32), 5.0)[0] == pytest.approx(0.1)
    with pytest.raises(ValueError, match="tolerance_m"):
        SelfHits(reach_m=0.3, tolerance_m=0.0)


def _trail_cells(slam: FastSlam, truth: np.ndarray) -> int:
    """Occupied cells of the best map within 0.3 m of the true path: the room has no wall there."""
    grid = slam.best_map()
    rows, cols = np.nonzero(grid.log_odds > 0)
    xy = grid.spec.cell_to_world(np.stack([rows, cols], 1))
    d = np.hypot(xy[:, None, 0] - truth[None, ::5, 0], xy[:, None, 1] - truth[None, ::5, 1]).min(axis=1)
    return int((d < 0.3).sum())


def test_a_filter_fed_its_own_body_draws_less_trail_and_tracks_better() -> None:
    """A robot that stands still for 4 s, then drives the loop of test_fastslam (turning in place at its corners)
    with 62 of its 720 beams on its own body: kept, those returns leave occupied cells along its path and pull the
    estimate off; dropped once a quarter turn in place has confirmed them, they leave those of the first sides."""
    rng = np.random.default_rng(7)
    truth = true_path()
    truth = np.concatenate([np.repeat(truth[:1], 40, axis=0), truth])
    odom = drifting_odometry(truth, rng)
    frames = [Frame(int(k * 1e8), Scan(with_own_body(cast(p, rng, RPLIDAR), rng), RPLIDAR), Pose2D.from_array(o))
              for k, (p, o) in enumerate(zip(truth, odom, strict=True))]
    trail, error, own, note = {}, {}, {}, {}
    for reach in (0.3, 0.0):
        slam = FastSlam(SlamConfig(n_particles=10, matching=MatchingConfig(self_hit_m=reach)), np.random.default_rng(0))
        for f in frames:
            slam.step(f)
        trail[reach] = _trail_cells(slam, truth)
        error[reach] = float(np.hypot(*(slam.trajectory().poses[:, :2] - truth[:, :2]).T).max())
        own[reach] = set(slam.self_hits.beams.tolist())
        note[reach] = slam.self_hit_note()
    assert own[0.3] == set(OWN_BEAMS.tolist()) and own[0.0] == set()
    assert note[0.0] is None and note[0.3] is not None and "62 beams (85, 86, 87, 88" in note[0.3]
    assert trail[0.0] >= 10 and trail[0.3] <= 0.6 * trail[0.0]  # what is left: written before the confirming turn
    assert error[0.3] <= error[0.0]
