"""Offline refinement (mcnkit.slam.refine): every scan moved onto the map of the other scans."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.slam.refine import refine_poses


def _room_returns(poses: np.ndarray, half_m: float = 3.025, n_beams: int = 360) -> list[np.ndarray]:
    """Noise-free returns (base frame) of a square room of side 2·half_m centred on the origin, with a pillar."""
    angles = np.linspace(-np.pi, np.pi, n_beams, endpoint=False)
    out = []
    for x, y, yaw in poses:
        a = yaw + angles
        c, s = np.cos(a), np.sin(a)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 0, (half_m - x) / c, (-half_m - x) / c)
            ty = np.where(s > 0, (half_m - y) / s, (-half_m - y) / s)
        r = np.minimum(np.abs(tx), np.abs(ty))
        out.append(np.column_stack([r * np.cos(angles), r * np.sin(angles)]))
    return out


def _circle(n: int, radius_m: float) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([radius_m * np.cos(t), radius_m * np.sin(t), (t + np.pi) % (2 * np.pi) - np.pi])


def _errors(poses: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    yaw = np.abs((poses[:, 2] - truth[:, 2] + np.pi) % (2 * np.pi) - np.pi)
    return np.hypot(*(poses[:, :2] - truth[:, :2]).T), np.degrees(yaw)


def test_a_misplaced_scan_among_consistent_ones_is_put_back() -> None:
    rng = np.random.default_rng(1)
    truth = _circle(60, 1.5)
    returns = _room_returns(truth)
    wrong = rng.choice(60, 10, replace=False)
    placed = truth.copy()
    placed[wrong] += np.column_stack([rng.normal(0, 0.05, (10, 2)), rng.normal(0, np.radians(1.0), 10)])
    xy_before, _ = _errors(placed, truth)
    xy, deg = _errors(refine_poses(placed, returns, 0.05), truth)
    assert xy_before[wrong].mean() > 0.04
    assert xy[wrong].max() < 0.01 and deg[wrong].max() < 0.2  # pulled back onto the other scans' walls
    assert xy.max() < 0.01  # and the others stay


def test_a_trajectory_noisy_everywhere_comes_closer_to_the_truth() -> None:
    rng = np.random.default_rng(2)
    truth = _circle(60, 1.5)
    noisy = truth + np.column_stack([rng.normal(0, 0.05, (60, 2)), rng.normal(0, np.radians(1.0), 60)])
    xy_before, deg_before = _errors(noisy, truth)
    xy, deg = _errors(refine_poses(noisy, _room_returns(truth), 0.05), truth)
    # every wall is blurred by the noise of all the scans that drew it: better, not exact
    assert np.sqrt(np.mean(xy**2)) < 0.85 * np.sqrt(np.mean(xy_before**2))
    assert deg.mean() < 0.85 * deg_before.mean()


def test_exact_poses_stay_and_no_pose_moves_more_than_allowed() -> None:
    truth = _circle(40, 1.0)
    returns = _room_returns(truth)
    assert np.abs(refine_poses(truth, returns, 0.05) - truth)[:, :2].max() < 0.02
    far = truth.copy()
    far[10, :2] += 2.0  # a pose 2.8 m off: refinement is no loop closer, it moves it by ≤ 0.3 m per pass
    moved = refine_poses(far, returns, 0.05, passes=1)
    assert np.hypot(*(moved[10, :2] - far[10, :2])) <= 0.3 + 1e-9


def test_too_few_scans_are_returned_as_they_are() -> None:
    poses = np.zeros((5, 3))
    assert np.array_equal(refine_poses(poses, _room_returns(poses), 0.05), poses)


def test_the_returns_may_come_as_a_generator_scan_by_scan() -> None:
    rng = np.random.default_rng(3)
    truth = _circle(40, 1.0)
    noisy = truth + np.column_stack([rng.normal(0, 0.03, (40, 2)), rng.normal(0, np.radians(0.5), 40)])
    returns = _room_returns(truth)
    # a long log's raw returns need not all exist at once: the same result from a generator as from the list
    assert np.array_equal(refine_poses(noisy, (r for r in returns), 0.05), refine_poses(noisy, returns, 0.05))


def test_a_count_of_scans_that_differs_from_the_poses_is_refused() -> None:
    poses = _circle(20, 1.0)
    with pytest.raises(ValueError, match="20 poses but 19 scans"):
        refine_poses(poses, iter(_room_returns(poses)[:19]), 0.05)
