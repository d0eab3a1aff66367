"""Wide, exact scan matching: branch and bound finds what brute force finds, refinement goes below a cell,
and the checks that keep a corridor from sliding a match along its axis."""

from __future__ import annotations

import math

import numpy as np

from mcnkit.geometry import compose
from mcnkit.slam.correlative import likelihood_grid, match_scan, thin_points
from mcnkit.slam.likelihood import refine_match, score_pose
from mcnkit.slam.proposal import cap_information, match_information


def _walls(segments: list[tuple[float, float, float, float]], step: float = 0.02) -> np.ndarray:
    pts = []
    for x0, y0, x1, y1 in segments:
        n = max(2, int(math.hypot(x1 - x0, y1 - y0) / step))
        t = np.linspace(0, 1, n)
        pts.append(np.c_[x0 + t * (x1 - x0), y0 + t * (y1 - y0)])
    return np.concatenate(pts) + 0.013  # off the cell corners


ROOM = _walls([(0, 0, 8, 0), (8, 0, 8, 5), (8, 5, 0, 5), (0, 5, 0, 0), (3, 0, 3, 2), (5.5, 5, 5.5, 3.5)])
CORRIDOR = _walls([(-20, 0, 20, 0), (-20, 2, 20, 2)])


def _scan_of(world: np.ndarray, pose: np.ndarray, reach: float = 6.0) -> np.ndarray:
    """The world points within ``reach`` of ``pose``, in its frame (a crude scan: no occlusion needed here)."""
    near = world[np.hypot(*(world - pose[:2]).T) < reach]
    c, s = math.cos(pose[2]), math.sin(pose[2])
    d = near - pose[:2]
    return np.c_[c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]]


def test_branch_and_bound_finds_the_brute_force_maximum() -> None:
    grid = likelihood_grid(ROOM, 0.05, sigma_m=0.1, margin_m=2.0)
    truth = np.array([4.0, 2.5, 0.2])
    scan = thin_points(_scan_of(ROOM, truth), 0.1)
    center = truth + np.array([0.4, -0.3, 0.08])
    step = math.radians(1.0)
    found = match_scan(grid, scan, center, 0.5, math.radians(6), angle_step_rad=step)
    best = -1.0
    for a in center[2] + step * np.arange(-6, 7):
        for dx in np.arange(-10, 11) * 0.05:
            for dy in np.arange(-10, 11) * 0.05:
                pose = np.array([center[0] + dx, center[1] + dy, a])
                pts = compose(pose, np.c_[scan, np.zeros(len(scan))])[:, :2]
                cells = np.floor((pts - [grid.origin_x_m, grid.origin_y_m]) / 0.05).astype(int)
                best = max(best, float(grid.levels[0][cells[:, 1], cells[:, 0]].mean()))
    assert math.isclose(found.score, best, rel_tol=1e-5)
    assert np.hypot(*(found.pose[:2] - truth[:2])) < 0.08 and abs(found.pose[2] - truth[2]) < math.radians(1.5)


def test_branch_and_bound_is_exact_where_the_scan_reaches_past_the_maps_lower_left_edge() -> None:
    # a robot entering new ground sees walls left of and below everything mapped so far: blocks of shifts that start
    # outside the grid but reach into it must still bound the scores of their shifts inside it
    mapped = ROOM[(ROOM[:, 0] > 2.0) & (ROOM[:, 1] > 1.0)]
    grid = likelihood_grid(mapped, 0.1, sigma_m=0.15, margin_m=0.1, depth=5)
    truth = np.array([3.5, 2.5, 0.0])
    scan = thin_points(_scan_of(ROOM, truth, reach=8.0), 0.1)
    step = math.radians(1.0)
    found = match_scan(grid, scan, truth, 1.5, math.radians(3), angle_step_rad=step)
    best = -1.0
    h, w = grid.levels[0].shape
    for a in truth[2] + step * np.arange(-3, 4):
        for dx in np.arange(-15, 16) * 0.1:
            for dy in np.arange(-15, 16) * 0.1:
                pose = np.array([truth[0] + dx, truth[1] + dy, a])
                pts = compose(pose, np.c_[scan, np.zeros(len(scan))])[:, :2]
                cells = np.floor((pts - [grid.origin_x_m, grid.origin_y_m]) / 0.1).astype(int)
                inside = (cells[:, 0] >= 0) & (cells[:, 0] < w) & (cells[:, 1] >= 0) & (cells[:, 1] < h)
                best = max(best, float(grid.levels[0][cells[inside, 1], cells[inside, 0]].sum()) / len(scan))
    assert math.isclose(found.score, best, rel_tol=1e-5)


def test_equal_scores_go_to_the_windows_centre() -> None:
    # along a corridor every shift scores the same: the match stays where it was asked to look
    grid = likelihood_grid(CORRIDOR, 0.1, sigma_m=0.15, margin_m=1.0)
    scan = thin_points(_scan_of(CORRIDOR, np.array([0.0, 1.0, 0.0])), 0.1)
    for x in (-1.3, 0.0, 2.2):
        found = match_scan(grid, scan, np.array([x, 1.0, 0.0]), 1.0, math.radians(2))
        assert abs(found.pose[0] - x) < 0.15


def test_refinement_goes_below_a_cell() -> None:
    grid = likelihood_grid(ROOM, 0.05, sigma_m=0.1, margin_m=2.0)
    truth = np.array([4.0, 2.5, 0.2])
    scan = thin_points(_scan_of(ROOM, truth), 0.05)
    coarse = match_scan(grid, scan, truth + np.array([0.3, 0.2, -0.05]), 0.5, 0.1)
    fine = refine_match(grid, scan, coarse.pose, 0.1)
    assert np.hypot(*(fine.pose[:2] - truth[:2])) < 0.02
    assert fine.score >= score_pose(grid, scan, coarse.pose)


def test_a_corridor_constrains_across_its_axis_but_not_along_it() -> None:
    grid = likelihood_grid(CORRIDOR, 0.05, sigma_m=0.1, margin_m=2.0)
    pose = np.array([0.0, 1.0, 0.0])
    info = match_information(grid, thin_points(_scan_of(CORRIDOR, pose), 0.1), pose, beams=20.0)
    across, along = info[1, 1], info[0, 0]
    assert across > 100.0 and along < 1e-3 * across
    capped = cap_information(info, np.array([400.0, 400.0, 3000.0]))
    assert capped[1, 1] <= 400.0 + 1e-6 and capped[0, 0] <= along + 1e-9  # never more precise than stated


def test_a_match_in_a_corridor_is_as_good_anywhere_along_it() -> None:
    """Why loop matches in corridors need the uniqueness test: two poses a metre apart score the same."""
    grid = likelihood_grid(CORRIDOR, 0.05, sigma_m=0.1, margin_m=2.0)
    pose = np.array([0.0, 1.0, 0.0])
    scan = thin_points(_scan_of(CORRIDOR, pose, reach=5.0), 0.1)
    assert abs(score_pose(grid, scan, pose) - score_pose(grid, scan, pose + np.array([1.0, 0, 0]))) < 0.02
