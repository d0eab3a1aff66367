"""On a likelihood field (:class:`~mcnkit.slam.correlative.LikelihoodGrid`): sub-cell refinement of a match, its
score, and the checks that tell a real match from a look-alike.

* :func:`refine_match`: Gauss-Newton on the bilinearly interpolated field (Kohlbrecher et al. 2011), from a
  branch-and-bound match one cell coarse to a fraction of a cell;
* :func:`score_pose`: the mean interpolated likelihood of a scan's points;
* :func:`free_space`, :func:`contradiction`, :func:`overlap`: where the map's own scans looked, and how many of a
  new scan's points land in space they saw empty (a wrong match puts end points in open rooms).

Example:
    >>> fine = refine_match(grid, scan_points, coarse.pose, max_shift_m=0.1)  # doctest: +SKIP
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from mcnkit.slam.correlative import LikelihoodGrid, ScanMatch

__all__ = ["contradiction", "free_space", "overlap", "refine_match", "score_pose"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]

_jit = numba.njit(cache=True, fastmath=True, error_model="numpy")


@_jit
def _bilinear(field: F32, x: float, y: float) -> tuple[float, float, float]:
    """Value and gradient (per cell) of the field at continuous cell coordinates (x, y) (cell centres at +0.5)."""
    h, w = field.shape
    fx = x - 0.5
    fy = y - 0.5
    ix = int(math.floor(fx))
    iy = int(math.floor(fy))
    if ix < 0 or iy < 0 or ix + 1 >= w or iy + 1 >= h:
        return 0.0, 0.0, 0.0
    ax = fx - ix
    ay = fy - iy
    v00 = field[iy, ix]
    v01 = field[iy, ix + 1]
    v10 = field[iy + 1, ix]
    v11 = field[iy + 1, ix + 1]
    v = (1 - ay) * ((1 - ax) * v00 + ax * v01) + ay * ((1 - ax) * v10 + ax * v11)
    gx = (1 - ay) * (v01 - v00) + ay * (v11 - v10)
    gy = (1 - ax) * (v10 - v00) + ax * (v11 - v01)
    return v, gx, gy


@_jit
def _refine(field: F32, x0: float, y0: float, res: float, px: F64, py: F64, pose: F64, iterations: int) -> F64:
    """Gauss-Newton on Σ (1 - L(T·p))² with L bilinearly interpolated (Kohlbrecher et al. 2011)."""
    out = pose.copy()
    for _ in range(iterations):
        c = math.cos(out[2])
        s = math.sin(out[2])
        h = np.zeros((3, 3))
        g = np.zeros(3)
        for i in range(px.shape[0]):
            wx = out[0] + c * px[i] - s * py[i]
            wy = out[1] + s * px[i] + c * py[i]
            v, gx, gy = _bilinear(field, (wx - x0) / res, (wy - y0) / res)
            gx /= res
            gy /= res
            jt = gx * (-s * px[i] - c * py[i]) + gy * (c * px[i] - s * py[i])
            r = 1.0 - v
            j0, j1, j2 = gx, gy, jt
            h[0, 0] += j0 * j0
            h[0, 1] += j0 * j1
            h[0, 2] += j0 * j2
            h[1, 1] += j1 * j1
            h[1, 2] += j1 * j2
            h[2, 2] += j2 * j2
            g[0] += j0 * r
            g[1] += j1 * r
            g[2] += j2 * r
        h[1, 0] = h[0, 1]
        h[2, 0] = h[0, 2]
        h[2, 1] = h[1, 2]
        for d in range(3):
            h[d, d] += 1e-6 + 1e-3 * h[d, d]
        step = np.linalg.solve(h, g)
        out += step
        if abs(step[0]) < 1e-4 and abs(step[1]) < 1e-4 and abs(step[2]) < 1e-5:
            break
    return out


def refine_match(grid: LikelihoodGrid, points_base: F64, pose: F64, max_shift_m: float, iterations: int = 10) -> ScanMatch:
    """Sub-cell refinement of a match by Gauss-Newton on the bilinearly interpolated field.

    The refined pose is kept only if it scores at least as well and stays within ``max_shift_m`` of ``pose``.
    """
    pts = np.ascontiguousarray(np.asarray(points_base, np.float64).reshape(-1, 2))
    pose = np.asarray(pose, np.float64)
    field = grid.levels[0]
    px, py = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
    out = _refine(field, grid.origin_x_m, grid.origin_y_m, grid.resolution_m, px, py, pose, iterations)
    before, after = score_pose(grid, pts, pose), score_pose(grid, pts, out)
    if not np.all(np.isfinite(out)) or after < before or np.hypot(*(out[:2] - pose[:2])) > max_shift_m:
        return ScanMatch(pose.copy(), before)
    out[2] = (out[2] + np.pi) % (2 * np.pi) - np.pi
    return ScanMatch(out, after)


@_jit
def _score_pose(field: F32, x0: float, y0: float, res: float, px: F64, py: F64, pose: F64) -> float:
    c = math.cos(pose[2])
    s = math.sin(pose[2])
    total = 0.0
    for i in range(px.shape[0]):
        v, _, _ = _bilinear(field, (pose[0] + c * px[i] - s * py[i] - x0) / res, (pose[1] + s * px[i] + c * py[i] - y0) / res)
        total += v
    return total / max(px.shape[0], 1)


def score_pose(grid: LikelihoodGrid, points_base: F64, pose: F64) -> float:
    """Mean bilinearly interpolated likelihood of the points (M, 2) seen from ``pose`` (3,)."""
    pts = np.asarray(points_base, np.float64).reshape(-1, 2)
    return float(_score_pose(grid.levels[0], grid.origin_x_m, grid.origin_y_m, grid.resolution_m,
                             np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]),
                             np.asarray(pose, np.float64)))


@_jit
def _mark_free(free: NDArray[np.bool_], x0: float, y0: float, res: float, sx: F64, sy: F64, ex: F64, ey: F64,
               margin_cells: int) -> None:
    """Marks the cells that the rays from sensor (sx[i], sy[i]) to end (ex[i], ey[i]) cross, stopping
    ``margin_cells`` before the end."""
    h, w = free.shape
    for i in range(ex.shape[0]):
        ox = (sx[i] - x0) / res
        oy = (sy[i] - y0) / res
        tx = (ex[i] - x0) / res
        ty = (ey[i] - y0) / res
        length = math.hypot(tx - ox, ty - oy)
        n = int(length) - margin_cells
        if n <= 0:
            continue
        dx = (tx - ox) / length
        dy = (ty - oy) / length
        for t in range(n):
            cx = int(math.floor(ox + dx * t))
            cy = int(math.floor(oy + dy * t))
            if 0 <= cx < w and 0 <= cy < h:
                free[cy, cx] = True


def free_space(grid: LikelihoodGrid, sensors_xy: F64, points_xy: F64, margin_m: float) -> NDArray[np.bool_]:
    """(H, W) True where a ray of the map's scans passed (sensor (K, 2) to hit point (K, 2), world frame),
    up to ``margin_m`` before the hit: cells seen empty."""
    free = np.zeros(grid.shape, bool)
    s = np.asarray(sensors_xy, np.float64).reshape(-1, 2)
    e = np.asarray(points_xy, np.float64).reshape(-1, 2)
    _mark_free(free, grid.origin_x_m, grid.origin_y_m, grid.resolution_m, np.ascontiguousarray(s[:, 0]),
               np.ascontiguousarray(s[:, 1]), np.ascontiguousarray(e[:, 0]), np.ascontiguousarray(e[:, 1]),
               int(math.ceil(margin_m / grid.resolution_m)))
    return free


def contradiction(grid: LikelihoodGrid, free: NDArray[np.bool_], points_base: F64, pose: F64,
                  min_likelihood: float) -> float:
    """Fraction of the scan's points (M, 2) seen from ``pose`` that land where the map saw empty space (``free``)
    and no hit explains them (likelihood below ``min_likelihood``): a wrong match puts end points in open rooms."""
    pts = np.asarray(points_base, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return 0.0
    c, s = math.cos(pose[2]), math.sin(pose[2])
    wx = pose[0] + c * pts[:, 0] - s * pts[:, 1]
    wy = pose[1] + s * pts[:, 0] + c * pts[:, 1]
    col = np.floor((wx - grid.origin_x_m) / grid.resolution_m).astype(np.int64)
    row = np.floor((wy - grid.origin_y_m) / grid.resolution_m).astype(np.int64)
    h, w = grid.shape
    inside = (col >= 0) & (row >= 0) & (col < w) & (row < h)
    bad = np.zeros(len(pts), bool)
    r, cc = row[inside], col[inside]
    bad[inside] = free[r, cc] & (grid.levels[0][r, cc] < min_likelihood)
    return float(np.count_nonzero(bad)) / len(pts)


def overlap(grid: LikelihoodGrid, free: NDArray[np.bool_], points_base: F64, pose: F64) -> float:
    """Fraction of the scan's points (M, 2) seen from ``pose`` that land where the map looked: on cells its
    rays crossed (``free``) or near its hits (likelihood ≥ 0.1)."""
    pts = np.asarray(points_base, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return 0.0
    c, s = math.cos(pose[2]), math.sin(pose[2])
    col = np.floor((pose[0] + c * pts[:, 0] - s * pts[:, 1] - grid.origin_x_m) / grid.resolution_m).astype(np.int64)
    row = np.floor((pose[1] + s * pts[:, 0] + c * pts[:, 1] - grid.origin_y_m) / grid.resolution_m).astype(np.int64)
    h, w = grid.shape
    inside = (col >= 0) & (row >= 0) & (col < w) & (row < h)
    r, cc = row[inside], col[inside]
    seen = free[r, cc] | (grid.levels[0][r, cc] >= 0.1)
    return float(np.count_nonzero(seen)) / len(pts)
