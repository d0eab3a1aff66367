"""Correlative scan matching over a wide window, exact, by branch and bound (Olson 2009; Hess et al. 2016).

A :class:`LikelihoodGrid` holds, for every cell of a local map, how well a beam end point falling there is
explained: ``exp(-d² / 2σ²)`` with ``d`` the distance from the cell centre to the nearest hit cell.  Its
*precomputation levels* hold, for level ``h``, the maximum of that likelihood over the ``2^h × 2^h`` block of
cells starting at each cell.

:func:`match_scan` finds the pose in a window (± ``window_xy_m`` in x and y, ± ``window_rad`` in heading)
around a centre that maximises the mean likelihood of the scan's points.  Headings are searched in steps
small enough that the farthest point moves by at most one cell; for every heading the translation is searched
by branch and bound: a coarse candidate at level ``h`` stands for the ``2^h × 2^h`` translations it covers,
and its score on level ``h`` bounds all of theirs from above, so whole blocks are pruned as soon as their
bound does not beat the best full-resolution score found.  The result is the exact maximum of the discrete
search, at a small fraction of the brute-force cost.

Example:
    >>> wall = np.linspace(-2.0, 2.0, 81) + 0.013
    >>> room = np.c_[np.r_[wall, wall * 0 + 2.03, wall], np.r_[wall * 0 + 2.02, wall, wall * 0 - 1.98]]
    >>> grid = likelihood_grid(room, 0.05, sigma_m=0.1, margin_m=1.0)
    >>> m = match_scan(grid, room, np.array([0.3, -0.2, 0.1]), 0.5, 0.2)  # the scan, seen from the origin
    >>> bool(np.abs(m.pose).max() < 0.06), m.score > 0.9
    (True, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["LikelihoodGrid", "ScanMatch", "angular_step", "likelihood_grid", "match_scan", "thin_points", "with_unseen"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
I64 = NDArray[np.int64]

_jit = numba.njit(cache=True, fastmath=True, error_model="numpy")


@dataclass(frozen=True)
class LikelihoodGrid:
    """A likelihood field on a grid and its max-pooled precomputation levels.

    ``levels[h]`` (H, W) float32: at cell (row, col), the maximum likelihood over rows ``row..row+2^h-1`` and
    columns ``col..col+2^h-1`` (``levels[0]`` is the field itself).  Cell (0, 0) has its lower-left corner at
    (``origin_x_m``, ``origin_y_m``).
    """

    origin_x_m: float
    origin_y_m: float
    resolution_m: float
    levels: tuple[F32, ...]
    hits: NDArray[np.bool_]
    """(H, W) True where a hit point lies."""

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) in cells."""
        h, w = self.levels[0].shape
        return int(h), int(w)


@dataclass(frozen=True)
class ScanMatch:
    """The best pose ``[x_m, y_m, yaw_rad]`` in the searched window and its score (mean likelihood, 0..1)."""

    pose: F64
    score: float


def thin_points(points_xy: F64, cell_m: float) -> F64:
    """One point (the first) per ``cell_m`` square: a scan's dense near returns stop outvoting its far ones."""
    pts = np.asarray(points_xy, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return pts
    keys = np.floor(pts / cell_m).astype(np.int64)
    _, first = np.unique(keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True)
    return pts[np.sort(first)]


@_jit
def _max_level(prev: F32, step: int) -> F32:
    """``out[r, c] = max(prev[r, c], prev[r, c+step], prev[r+step, c], prev[r+step, c+step])`` (0 outside)."""
    h, w = prev.shape
    out = np.empty_like(prev)
    for r in range(h):
        r2 = r + step
        for c in range(w):
            c2 = c + step
            m = prev[r, c]
            if c2 < w and prev[r, c2] > m:
                m = prev[r, c2]
            if r2 < h:
                if prev[r2, c] > m:
                    m = prev[r2, c]
                if c2 < w and prev[r2, c2] > m:
                    m = prev[r2, c2]
            out[r, c] = m
    return out


@_jit
def _stamp(hits: NDArray[np.bool_], kernel: F32) -> F32:
    """``out[c] = max over hit cells h of kernel[h - c]`` (the kernel centred on each hit)."""
    h, w = hits.shape
    r = kernel.shape[0] // 2
    out = np.zeros((h, w), np.float32)
    for y in range(h):
        for x in range(w):
            if not hits[y, x]:
                continue
            for dy in range(-r, r + 1):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                for dx in range(-r, r + 1):
                    xx = x + dx
                    if 0 <= xx < w:
                        v = kernel[dy + r, dx + r]
                        if v > out[yy, xx]:
                            out[yy, xx] = v
    return out


def _levels(field: F32, depth: int) -> tuple[F32, ...]:
    """``field`` and its ``depth`` max-pooled precomputation levels (see :class:`LikelihoodGrid`)."""
    levels = [field]
    for k in range(1, depth + 1):
        levels.append(_max_level(levels[-1], 1 << (k - 1)))
    return tuple(levels)


def likelihood_grid(
    points_xy: F64, resolution_m: float, sigma_m: float, margin_m: float, depth: int = 6
) -> LikelihoodGrid:
    """The likelihood field of hit points (K, 2) in metres on a grid covering them ± ``margin_m``.

    Args:
        points_xy: the map's hit points (world frame).
        resolution_m: cell size.
        sigma_m: standard deviation of the beam end point around a hit.
        margin_m: border around the points (at least the search window plus the scan's reach).
        depth: number of precomputation levels above the field (level ``depth`` pools ``2^depth`` cells).
    """
    pts = np.asarray(points_xy, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        raise ValueError("a likelihood grid needs at least one hit point")
    res = float(resolution_m)
    x0 = math.floor((pts[:, 0].min() - margin_m) / res) * res
    y0 = math.floor((pts[:, 1].min() - margin_m) / res) * res
    w = int(math.floor((pts[:, 0].max() + margin_m - x0) / res)) + 1
    h = int(math.floor((pts[:, 1].max() + margin_m - y0) / res)) + 1
    hits = np.zeros((h, w), bool)
    hits[np.floor((pts[:, 1] - y0) / res).astype(np.int64), np.floor((pts[:, 0] - x0) / res).astype(np.int64)] = True
    # exp(-d²/2σ²) of the distance d to the nearest hit, stamped around each hit out to 3.5 σ (beyond: < 0.22 %)
    radius = int(math.ceil(3.5 * sigma_m / res))
    offsets = np.arange(-radius, radius + 1) * res
    kernel = np.exp(-0.5 * (offsets[:, None] ** 2 + offsets[None, :] ** 2) / sigma_m**2).astype(np.float32)
    field = _stamp(hits, kernel)
    return LikelihoodGrid(x0, y0, res, _levels(field, depth), hits)


def with_unseen(grid: LikelihoodGrid, seen: NDArray[np.bool_], value: float) -> LikelihoodGrid:
    """``grid`` with every cell no scan has seen (``seen`` (H, W) False, on the grid's cells) explaining an end point
    at least ``value``: a return that lands where the map knows nothing is neither confirmed nor contradicted
    (the ternary maps' unknown 0.5), where the plain field calls it unexplained, as it calls a return in space the
    scans saw free.  Without this a scan that reaches past the map's edge scores below a pose that folds it back
    onto walls already mapped, and a look-alike pose a quarter turn off beats the true one."""
    field = grid.levels[0]
    if seen.shape != field.shape:
        raise ValueError(f"seen mask {seen.shape} is not on the grid's {field.shape} cells")
    lifted = np.where(seen, field, np.maximum(field, np.float32(value))).astype(np.float32)
    return LikelihoodGrid(grid.origin_x_m, grid.origin_y_m, grid.resolution_m, _levels(lifted, len(grid.levels) - 1),
                          grid.hits)


def angular_step(points_xy: F64, resolution_m: float, max_step_rad: float = math.radians(1.0)) -> float:
    """A heading step that moves the scan's far points (95th percentile of their range) by about one cell."""
    r = np.hypot(points_xy[:, 0], points_xy[:, 1]) if len(points_xy) else np.ones(1)
    far = max(float(np.percentile(r, 95)), 4.0 * resolution_m)
    return min(max_step_rad, math.acos(max(-1.0, 1.0 - resolution_m**2 / (2.0 * far**2))))


@_jit
def _level_score(level: F32, cx: I64, cy: I64, dx: int, dy: int, span: int) -> float:
    """The bound of the translations ``dx..dx+span-1`` × ``dy..dy+span-1`` on a level pooling ``span`` cells: a
    point whose block starts left of or below the grid but reaches into it is scored on the grid's first column or
    row (which pools a superset of the block's cells inside it), so the bound holds at the grid's edges too."""
    h, w = level.shape
    s = 0.0
    for i in range(cx.shape[0]):
        x = cx[i] + dx
        y = cy[i] + dy
        if x < 0 and x + span > 0:
            x = 0
        if y < 0 and y + span > 0:
            y = 0
        if 0 <= x < w and 0 <= y < h:
            s += level[y, x]
    return s


@_jit
def _off_centre(a: int, a_mid: int, x: int, y: int, span: int) -> float:
    """How far a block of ``span`` × ``span`` shifts at angle ``a`` lies from the window's centre (angle steps plus
    cells): among equal scores the nearer one is explored first, so a tie (a corridor's axis) goes to the centre
    instead of the window's edge.  Scaled to break ties only (far below any score difference)."""
    return 1e-9 * (abs(a - a_mid) + 0.5 * (abs(2 * x + span - 1) + abs(2 * y + span - 1)))


@_jit
def _branch_and_bound(
    levels: tuple[F32, ...], cells_x: I64, cells_y: I64, n_points: int, x_lo: int, x_hi: int, y_lo: int, y_hi: int,
    min_total: float,
) -> tuple[int, int, int, float]:
    """Best (angle index, dx, dy, total score) over headings (rows of ``cells_x``/``cells_y``) and integer
    shifts in [x_lo, x_hi] × [y_lo, y_hi]; ``min_total``: scores not above it are not reported (-1 angle)."""
    depth = len(levels) - 1
    n_angles = cells_x.shape[0] // n_points
    top = 1 << depth
    # the stack holds (level, angle, dx, dy, bound); each node's children go on top, best bound last
    cap = 64 + 4 * depth * 8
    n0 = n_angles * ((x_hi - x_lo) // top + 1) * ((y_hi - y_lo) // top + 1)
    stack_l = np.empty(n0 + cap * 8, np.int64)
    stack_a = np.empty(n0 + cap * 8, np.int64)
    stack_x = np.empty(n0 + cap * 8, np.int64)
    stack_y = np.empty(n0 + cap * 8, np.int64)
    stack_s = np.empty(n0 + cap * 8, np.float64)
    # root candidates, scored on the top level, pushed in increasing order so the best is popped first
    k = 0
    for a in range(n_angles):
        cx = cells_x[a * n_points : (a + 1) * n_points]
        cy = cells_y[a * n_points : (a + 1) * n_points]
        for dx in range(x_lo, x_hi + 1, top):
            for dy in range(y_lo, y_hi + 1, top):
                stack_l[k] = depth
                stack_a[k] = a
                stack_x[k] = dx
                stack_y[k] = dy
                stack_s[k] = _level_score(levels[depth], cx, cy, dx, dy, top)
                k += 1
    a_mid = (n_angles - 1) // 2
    keys = np.empty(k)
    for i in range(k):
        keys[i] = stack_s[i] - _off_centre(stack_a[i], a_mid, stack_x[i], stack_y[i], top)
    order = np.argsort(keys)
    stack_l[:k] = stack_l[:k][order]
    stack_a[:k] = stack_a[:k][order]
    stack_x[:k] = stack_x[:k][order]
    stack_y[:k] = stack_y[:k][order]
    stack_s[:k] = stack_s[:k][order]
    best_a, best_x, best_y, best_s = -1, 0, 0, min_total
    child_s = np.empty(4)
    child_key = np.empty(4)
    child_x = np.empty(4, np.int64)
    child_y = np.empty(4, np.int64)
    while k > 0:
        k -= 1
        lev, a, dx, dy, bound = stack_l[k], stack_a[k], stack_x[k], stack_y[k], stack_s[k]
        if bound <= best_s:
            continue
        if lev == 0:
            best_a, best_x, best_y, best_s = a, dx, dy, bound
            continue
        half = 1 << (lev - 1)
        cx = cells_x[a * n_points : (a + 1) * n_points]
        cy = cells_y[a * n_points : (a + 1) * n_points]
        n_child = 0
        for ox in (0, half):
            for oy in (0, half):
                x = dx + ox
                y = dy + oy
                if x > x_hi or y > y_hi:
                    continue
                s = _level_score(levels[lev - 1], cx, cy, x, y, half)
                if s > best_s:
                    child_x[n_child] = x
                    child_y[n_child] = y
                    child_s[n_child] = s
                    child_key[n_child] = s - _off_centre(a, a_mid, x, y, half)
                    n_child += 1
        # push worst first so the best child is explored first
        for _ in range(n_child):
            j = 0
            for t in range(1, n_child):
                if child_key[t] < child_key[j]:
                    j = t
            if k >= stack_l.shape[0]:
                grow = stack_l.shape[0]
                stack_l = np.concatenate((stack_l, np.empty(grow, np.int64)))
                stack_a = np.concatenate((stack_a, np.empty(grow, np.int64)))
                stack_x = np.concatenate((stack_x, np.empty(grow, np.int64)))
                stack_y = np.concatenate((stack_y, np.empty(grow, np.int64)))
                stack_s = np.concatenate((stack_s, np.empty(grow, np.float64)))
            stack_l[k] = lev - 1
            stack_a[k] = a
            stack_x[k] = child_x[j]
            stack_y[k] = child_y[j]
            stack_s[k] = child_s[j]
            k += 1
            child_key[j] = np.inf  # taken
    return best_a, best_x, best_y, best_s


def match_scan(
    grid: LikelihoodGrid,
    points_base: F64,
    center: F64,
    window_xy_m: float | tuple[float, float, float, float],
    window_rad: float,
    angle_step_rad: float | None = None,
    min_score: float = 0.0,
) -> ScanMatch:
    """The pose within the window around ``center`` (3,) that best explains the points (M, 2), base frame.

    ``window_xy_m``: ± that much in x and y, or a box ``(x_lo, x_hi, y_lo, y_hi)`` of offsets from the centre.
    The translation is searched on the grid's cells, the heading in steps of ``angle_step_rad`` (default
    :func:`angular_step`) within ± ``window_rad``.  Returns the centre with score 0 when no pose scores above
    ``min_score``.
    """
    pts = np.asarray(points_base, np.float64).reshape(-1, 2)
    center = np.asarray(center, np.float64)
    if len(pts) == 0:
        return ScanMatch(center.copy(), 0.0)
    res = grid.resolution_m
    if isinstance(window_xy_m, tuple):
        box = window_xy_m
    else:
        w = float(window_xy_m)
        box = (-w, w, -w, w)
    x_lo, x_hi = math.ceil(box[0] / res), math.floor(box[1] / res)
    y_lo, y_hi = math.ceil(box[2] / res), math.floor(box[3] / res)
    if x_lo > x_hi or y_lo > y_hi:
        return ScanMatch(center.copy(), 0.0)
    step = angular_step(pts, res) if angle_step_rad is None else float(angle_step_rad)
    n_half = int(math.ceil(window_rad / step)) if window_rad > 0 else 0
    angles = center[2] + step * np.arange(-n_half, n_half + 1)
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    wx_m = center[0] + c * pts[None, :, 0] - s * pts[None, :, 1]  # (A, M) world points at the centre's xy
    wy_m = center[1] + s * pts[None, :, 0] + c * pts[None, :, 1]
    cells_x = np.floor((wx_m - grid.origin_x_m) / res).astype(np.int64).ravel()
    cells_y = np.floor((wy_m - grid.origin_y_m) / res).astype(np.int64).ravel()
    a, dx, dy, total = _branch_and_bound(
        grid.levels, cells_x, cells_y, len(pts), x_lo, x_hi, y_lo, y_hi, min_score * len(pts)
    )
    if a < 0:
        return ScanMatch(center.copy(), 0.0)
    pose = np.array([center[0] + dx * res, center[1] + dy * res, angles[a]])
    pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
    return ScanMatch(pose, float(total) / len(pts))
