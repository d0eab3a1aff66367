"""A dense, per-particle copy of the map near a scan, so the matcher reads arrays instead of tile tables.

The window covers the tiles within ``reach_tiles`` of a set of predicted end points.  For one particle at a
time, :func:`fill_window` copies the mean hit point of every cell of those tiles into ``(H, W, 2)``
(offsets from the cell corner, -1 where no hit), and empties them again afterwards.  End points that move
out of the usable tiles during hill climbing fall back to the tile tables, so results never depend on it.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from mcnkit.geometry import compose

__all__ = ["WINDOW_MAX_CELLS", "WINDOW_RANGE_M", "MapArrays", "Window", "end_points", "fill_window", "no_window", "window"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
I32 = NDArray[np.int32]
I64 = NDArray[np.int64]
U8 = NDArray[np.uint8]
MapArrays = tuple[I32, int, int, int, I32, F32, F32]  # table, tx0, ty0, shift, count, mean_x, mean_y
# Mean hit offsets (H, W, 2), -1 where no hit; per tile, 1 where a 3 x 3 neighbourhood centred in it lies in
# copied tiles; the copied tiles (K, 2) as (row, col); the global cell of window cell (0, 0).
Window = tuple[F32, U8, I64, int, int]

_jit = numba.njit(cache=True, fastmath=True, error_model="numpy")


@_jit
def fill_window(maps: MapArrays, p: int, win: Window, fill: bool) -> None:
    """Copies particle ``p``'s tiles listed in the window into it (``fill``), or empties them again."""
    wm, _, tiles, wx0, wy0 = win
    table, tx0, ty0, shift, count, mean_x, mean_y = maps
    side = 1 << shift
    for k in range(tiles.shape[0]):
        lty, ltx = tiles[k, 0], tiles[k, 1]
        if not fill:
            wm[lty * side : (lty + 1) * side, ltx * side : (ltx + 1) * side, 0] = -1.0
            continue
        gty = (wy0 >> shift) + lty - ty0
        gtx = (wx0 >> shift) + ltx - tx0
        if gty < 0 or gtx < 0 or gty >= table.shape[1] or gtx >= table.shape[2]:
            continue
        t = table[p, gty, gtx]
        if t < 0:
            continue
        base = t << (2 * shift)
        for cy in range(side):
            for cx in range(side):
                c = base + (cy << shift) + cx
                if count[c] > 0:
                    wm[lty * side + cy, ltx * side + cx, 0] = mean_x[c]  # mean hit point - cell corner
                    wm[lty * side + cy, ltx * side + cx, 1] = mean_y[c]


def no_window() -> Window:
    """An empty window: every lookup goes to the tile tables."""
    return np.zeros((0, 0, 2), np.float32), np.zeros((0, 0), np.uint8), np.zeros((0, 2), np.int64), 0, 0


WINDOW_MAX_CELLS = 1 << 23
"""A window whose bounding box would hold more cells than this (64 MB of float32 pairs: 145 m square at 5 cm) is
not made: particles spread that far apart are matched through the tile tables alone, with the same results."""


def window(points_xy: F64, res: float, shift: int, reach_tiles: int) -> Window:
    """A window in which tiles within ``reach_tiles`` of any of the points (K, 2) are usable (:func:`no_window`
    where its bounding box would exceed ``WINDOW_MAX_CELLS``)."""
    tiles = np.floor(points_xy / res).astype(np.int64) >> shift  # (K, 2) as (tx, ty)
    lo = tiles.min(axis=0) - reach_tiles - 1
    hi = tiles.max(axis=0) + reach_tiles + 1
    th, tw = int(hi[1] - lo[1] + 1), int(hi[0] - lo[0] + 1)
    if th * tw << (2 * shift) > WINDOW_MAX_CELLS:
        return no_window()
    hit = np.zeros((th, tw), bool)
    hit[tiles[:, 1] - lo[1], tiles[:, 0] - lo[0]] = True
    usable = ndimage.binary_dilation(hit, np.ones((3, 3), bool), iterations=reach_tiles)
    copied = ndimage.binary_dilation(usable, np.ones((3, 3), bool))
    side = 1 << shift
    wm = np.full((th * side, tw * side, 2), -1.0, np.float32)
    tiles_rc = np.ascontiguousarray(np.argwhere(copied), dtype=np.int64)  # C order: one compiled signature
    return wm, usable.astype(np.uint8), tiles_rc, int(lo[0]) * side, int(lo[1]) * side


WINDOW_RANGE_M = 20.0
"""Only end points this close to the robot shape the dense window (a long-range scanner's far returns would
make it hundreds of megabytes); farther ones are looked up in the tiles."""


def end_points(poses: F64, end_xy: F64, max_range_m: float = WINDOW_RANGE_M) -> F64:
    """World end points (N·M', 2) of the beams (M, 2) within ``max_range_m`` of the base, seen from poses (N, 3)."""
    near = end_xy[np.hypot(end_xy[:, 0], end_xy[:, 1]) <= max_range_m]
    if len(near) == 0:
        near = end_xy[:1]
    ends = compose(poses[:, None, :], np.concatenate([near, np.zeros((len(near), 1))], axis=1))
    return ends[..., :2].reshape(-1, 2)
