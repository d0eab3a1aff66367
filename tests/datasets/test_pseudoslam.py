"""HouseExpo's Pseudo-SLAM reproduced on a hand-made room."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.datasets.pseudoslam import (
    PseudoSlamConfig,
    exploration,
    first_iteration,
    pseudo_slam_scan,
    random_start_pose,
)
from mcnkit.types import FREE, OCCUPIED, UNKNOWN


@pytest.fixture
def room() -> np.ndarray:
    free = np.zeros((20, 20), bool)
    free[2:18, 2:18] = True  # walls/exterior: rows/cols 0-1 and 18-19
    return free


def test_default_config_is_houseexpos() -> None:
    cfg = PseudoSlamConfig()
    assert (cfg.range_px, cfg.robot_radius_px, len(cfg.beam_angles_rad)) == (32, 3, 180)
    assert cfg.beam_angles_rad[0] == pytest.approx(-np.pi / 2)
    assert cfg.beam_angles_rad[-1] == pytest.approx(np.deg2rad(89.0))


def test_scan_in_hand_made_room(room: np.ndarray) -> None:
    cfg = PseudoSlamConfig(range_m=0.5, px_per_m=16.0)  # 8 px
    obs = pseudo_slam_scan(room, (10.0, 10.0, 0.0), cfg)
    # Straight ahead (+x = +col): free up to the wall at col 18, which is seen, nothing beyond.
    assert np.all(obs[10, 10:18] == FREE)
    assert obs[10, 18] == OCCUPIED and obs[10, 19] == UNKNOWN
    # Behind the robot (-x) is outside the 180° field of view.
    assert np.all(obs[10, 2:10] == UNKNOWN)
    # To the right (-90°, first beam: -y = lower rows): 8 px of free space, the wall at row 1 is out of range.
    assert np.all(obs[2:11, 10] == FREE) and obs[1, 10] == UNKNOWN
    # +90° is excluded (np.arange), but +89° reaches 8 px up to row 18 = wall.
    assert obs[18, 10] == UNKNOWN or obs[18, 10] == OCCUPIED
    # Whatever is observed equals the ground truth.
    seen = obs != UNKNOWN
    np.testing.assert_array_equal(obs[seen], np.where(room, FREE, OCCUPIED)[seen])
    # Nothing farther than the range (plus pixel rounding) is observed.
    rr, cc = np.nonzero(seen)
    assert np.hypot(rr - 10, cc - 10).max() <= cfg.range_px + np.sqrt(0.5)  # rounding of both coordinates


def test_walls_stop_rays(room: np.ndarray) -> None:
    room = room.copy()
    room[5:15, 13] = False  # an inner wall 3 px ahead
    obs = pseudo_slam_scan(room, (10.0, 10.0, 0.0), PseudoSlamConfig(range_m=0.5, px_per_m=16.0))
    assert obs[10, 13] == OCCUPIED
    assert np.all(obs[8:13, 14:18] == UNKNOWN)


def test_random_start_pose_is_safe_and_in_window() -> None:
    free = np.zeros((100, 100), bool)
    free[10:90, 10:90] = True
    cfg = PseudoSlamConfig()
    rng = np.random.default_rng(0)
    for _ in range(50):
        r, c, yaw = random_start_pose(free, cfg, rng)
        assert 10 <= r < 80 and 10 <= c < 80
        assert r >= 13 and c >= 13  # robot disc (3 px) clear of the walls at row/col 9
        assert 0.0 <= yaw < 2 * np.pi


def test_first_iteration_deterministic(room: np.ndarray) -> None:
    a = first_iteration(room, PseudoSlamConfig(), np.random.default_rng(7))
    b = first_iteration(room, PseudoSlamConfig(), np.random.default_rng(7))
    assert a.pose_px == b.pose_px
    np.testing.assert_array_equal(a.observed, b.observed)
    np.testing.assert_array_equal(a.ground_truth, np.where(room, FREE, OCCUPIED))


def test_no_free_pixel_raises() -> None:
    with pytest.raises(ValueError, match="no free pixel"):
        random_start_pose(np.zeros((10, 10), bool), PseudoSlamConfig(), np.random.default_rng(0))


@pytest.fixture
def two_rooms() -> np.ndarray:
    """Two 16 × 16 px rooms joined by a 6 px door in the wall at rows 18-19."""
    free = np.zeros((38, 20), bool)
    free[2:18, 2:18] = True
    free[20:36, 2:18] = True
    free[18:20, 7:13] = True
    return free


def test_exploration_of_one_scan_is_the_first_iteration(two_rooms: np.ndarray) -> None:
    cfg = PseudoSlamConfig(range_m=4.0, fov_deg=360.0)
    a = exploration(two_rooms, cfg, 1, np.random.default_rng(3))
    b = first_iteration(two_rooms, cfg, np.random.default_rng(3))
    np.testing.assert_array_equal(a.observed, b.observed)
    assert a.pose_px == b.pose_px


def test_exploration_grows_the_map_and_never_contradicts_the_truth(two_rooms: np.ndarray) -> None:
    cfg = PseudoSlamConfig(range_m=4.0, fov_deg=360.0)
    known = [(exploration(two_rooms, cfg, n, np.random.default_rng(3)).observed != UNKNOWN) for n in (1, 4, 30)]
    assert known[0].sum() <= known[1].sum() <= known[2].sum()
    assert known[0].sum() < known[2].sum()
    obs = exploration(two_rooms, cfg, 30, np.random.default_rng(3))
    seen = obs.observed != UNKNOWN
    np.testing.assert_array_equal(obs.observed[seen], obs.ground_truth[seen])
    # After 30 scans from poses the robot could reach, both rooms are seen (the door lets it through).
    assert (obs.observed[two_rooms] == FREE).mean() > 0.95


def test_exploration_needs_a_scan(room: np.ndarray) -> None:
    with pytest.raises(ValueError, match="n_scans"):
        exploration(room, PseudoSlamConfig(), 0, np.random.default_rng(0))
