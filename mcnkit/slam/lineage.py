"""The occupancy map of one particle's lineage, kept up to date by differences instead of rebuilt.

A particle's output map is its update scans ray-cast from its corrected poses
(:func:`~mcnkit.slam.raycast.ray_cast_counts`).  Rebuilding that at every filter update costs time quadratic in
the run's length.  A :class:`LineageMap` holds the hit and pass counts of one sequence of poses;
:meth:`LineageMap.sync` moves it to another particle's poses by removing the scans whose pose changed and
casting them again at the new pose.
Lineages share their ancestry (resampling makes the particles coalesce a few updates back), so a sync
usually touches the last few scans only.  The result is exactly :func:`ray_cast_counts` of those poses.

:meth:`LineageMap.pooled` reads a coarse window of the map straight from the counts, with the priority
``occupied > free > unknown`` of :func:`mcnkit.grid.resize_ternary` over the cells in each window cell: the
network's 64 × 64 input, without building the full-resolution image.

Example:
    >>> lm = LineageMap(0.05, angles, laser, max_range_m=30.0, usable_m=30.0, occ_thresh=0.25)  # doctest: +SKIP
    >>> lm.sync(slam.update_poses(particle), slam.update_ranges)                            # doctest: +SKIP
    >>> lm.ternary().image.shape                                                             # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba
import numpy as np
from numpy.typing import NDArray

from mcnkit.slam.raycast import cast_scan, scan_end_points
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec, TernaryMap

__all__ = ["LineageMap"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
I32 = NDArray[np.int32]


@numba.njit(cache=True)
def _pool(
    ranks: NDArray[np.int8], ix0: int, iy0: int, res: float, ox: float, oy: float, wres: float, rows: int, cols: int,
) -> NDArray[np.int8]:
    """Ranks (0 unknown, 1 free, 2 occupied) on a ``rows × cols`` window of cell size ``wres`` with its lower-left
    corner at (ox, oy): each window cell takes the highest rank of the map cells whose centres fall in it."""
    out = np.zeros((rows, cols), np.int8)
    h, w = ranks.shape
    c_lo = max(0, int(math.floor(ox / res)) - ix0)
    c_hi = min(w, int(math.ceil((ox + cols * wres) / res)) - ix0 + 1)
    r_lo = max(0, int(math.floor(oy / res)) - iy0)
    r_hi = min(h, int(math.ceil((oy + rows * wres) / res)) - iy0 + 1)
    col_of = np.empty(c_hi - c_lo if c_hi > c_lo else 0, np.int64)
    for x in range(c_lo, c_hi):
        col_of[x - c_lo] = int(math.floor(((ix0 + x + 0.5) * res - ox) / wres))
    for y in range(r_lo, r_hi):
        rr = int(math.floor(((iy0 + y + 0.5) * res - oy) / wres))
        if rr < 0 or rr >= rows:
            continue
        for x in range(c_lo, c_hi):
            rank = ranks[y, x]
            if rank == 0:
                continue
            cc = col_of[x - c_lo]
            if 0 <= cc < cols and rank > out[rr, cc]:
                out[rr, cc] = rank
    return out


_VALUE_OF_RANK = np.array([UNKNOWN, FREE, OCCUPIED], np.float32)


class LineageMap:
    """Hit and pass counts (int32) of one lineage's update scans, on a grid that grows as scans leave it."""

    def __init__(self, resolution_m: float, angles_rad: F64, base_to_laser: F64, *, max_range_m: float,
                 usable_m: float, occ_thresh: float, grow_m: float = 10.0) -> None:
        self.resolution_m = float(resolution_m)
        self.angles_rad = np.asarray(angles_rad, np.float64)
        self.base_to_laser = np.asarray(base_to_laser, np.float64)
        self.max_range_m = float(max_range_m)
        self.usable_m = float(usable_m)
        self.occ_thresh = float(occ_thresh)
        self.grow_cells = max(1, int(round(grow_m / resolution_m)))
        self.poses = np.zeros((0, 3))
        """Base poses (K, 3) of the scans now in the counts."""
        self.hits = np.zeros((0, 0), np.int32)
        self.passes = np.zeros((0, 0), np.int32)
        self.ranks = np.zeros((0, 0), np.int8)
        """Per cell 0 unknown, 1 free, 2 occupied, kept in step with the counts."""
        self.ix0 = 0
        self.iy0 = 0
        self._seen_lo = np.array([np.iinfo(np.int64).max] * 2)  # (ix, iy) bounds of every cell ever cast
        self._seen_hi = np.array([np.iinfo(np.int64).min] * 2)

    @property
    def spec(self) -> GridSpec:
        """The grid of the count arrays."""
        h, w = self.hits.shape
        return GridSpec(self.resolution_m, self.ix0 * self.resolution_m, self.iy0 * self.resolution_m,
                        max(w, 1), max(h, 1))

    def sync_cost(self, poses: F64) -> int:
        """How many scans :meth:`sync` to ``poses`` would cast (to give each lineage the nearest map)."""
        poses = np.asarray(poses, np.float64)
        common = min(len(poses), len(self.poses))
        changed = int(np.count_nonzero(np.any(self.poses[:common] != poses[:common], axis=1)))
        return 2 * changed + (len(self.poses) - common) + (len(poses) - common)

    def sync(self, poses: F64, ranges: Sequence[NDArray[np.floating]]) -> int:
        """Makes the counts those of scans ``ranges[k]`` at base poses ``poses[k]``; returns the scans cast.

        ``ranges`` holds every update scan so far; ``poses`` (K, 3) the lineage's poses at the first K of them.
        """
        poses = np.asarray(poses, np.float64)
        k_new, k_old = len(poses), len(self.poses)
        common = min(k_new, k_old)
        changed = np.flatnonzero(np.any(self.poses[:common] != poses[:common], axis=1))
        gone = np.concatenate([changed, np.arange(common, k_old)]).astype(np.int64)
        come = np.concatenate([changed, np.arange(common, k_new)]).astype(np.int64)
        for k in gone:
            self._cast(self.poses[k], ranges[k], -1)
        for k in come:
            self._cast(poses[k], ranges[k], +1)
        self.poses = poses.copy()
        return len(gone) + len(come)

    def _cast(self, pose: F64, ranges_m: NDArray[np.floating], sign: int) -> None:
        c, sn = math.cos(pose[2]), math.sin(pose[2])
        bx, by, bt = self.base_to_laser
        lx, ly, lt = pose[0] + c * bx - sn * by, pose[1] + sn * bx + c * by, pose[2] + bt
        ex, ey, hit = scan_end_points(lx, ly, lt, np.asarray(ranges_m, np.float32), self.angles_rad, self.max_range_m,
                                 self.usable_m)
        res = self.resolution_m
        lo = np.array([math.floor(min(ex.min(initial=lx), lx) / res), math.floor(min(ey.min(initial=ly), ly) / res)])
        hi = np.array([math.floor(max(ex.max(initial=lx), lx) / res), math.floor(max(ey.max(initial=ly), ly) / res)])
        self._ensure(lo, hi)
        self._seen_lo = np.minimum(self._seen_lo, lo)
        self._seen_hi = np.maximum(self._seen_hi, hi)
        cast_scan(self.hits, self.passes, self.ranks, self.ix0, self.iy0, res, lx, ly, ex, ey, hit, sign,
                     self.occ_thresh)

    def _ensure(self, lo: NDArray[np.int64], hi: NDArray[np.int64]) -> None:
        """Grows the count arrays (by ``grow_m`` beyond the need) so cells ``lo..hi`` (ix, iy) are inside."""
        h, w = self.hits.shape
        if h and lo[0] >= self.ix0 and lo[1] >= self.iy0 and hi[0] < self.ix0 + w and hi[1] < self.iy0 + h:
            return
        g = self.grow_cells
        if h:
            nx0 = min(self.ix0, int(lo[0]) - g) if lo[0] < self.ix0 else self.ix0
            ny0 = min(self.iy0, int(lo[1]) - g) if lo[1] < self.iy0 else self.iy0
            nx1 = max(self.ix0 + w, int(hi[0]) + 1 + g) if hi[0] >= self.ix0 + w else self.ix0 + w
            ny1 = max(self.iy0 + h, int(hi[1]) + 1 + g) if hi[1] >= self.iy0 + h else self.iy0 + h
        else:
            nx0, ny0, nx1, ny1 = int(lo[0]) - g, int(lo[1]) - g, int(hi[0]) + 1 + g, int(hi[1]) + 1 + g
        hits = np.zeros((ny1 - ny0, nx1 - nx0), np.int32)
        passes = np.zeros_like(hits)
        ranks = np.zeros(hits.shape, np.int8)
        if h:
            rows = slice(self.iy0 - ny0, self.iy0 - ny0 + h)
            cols = slice(self.ix0 - nx0, self.ix0 - nx0 + w)
            hits[rows, cols] = self.hits
            passes[rows, cols] = self.passes
            ranks[rows, cols] = self.ranks
        self.hits, self.passes, self.ranks, self.ix0, self.iy0 = hits, passes, ranks, nx0, ny0

    def seen_bounds_m(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` in metres of every cell a scan has touched (a superset once scans
        were removed)."""
        if self._seen_hi[0] < self._seen_lo[0]:
            raise RuntimeError("the lineage map holds no scan yet")
        res = self.resolution_m
        return (float(self._seen_lo[0] * res), float(self._seen_lo[1] * res),
                float((self._seen_hi[0] + 1) * res), float((self._seen_hi[1] + 1) * res))

    def ternary(self, crop: bool = True, max_cells: int | None = None) -> TernaryMap:
        """The ternary map (cropped to the seen cells unless ``crop=False``), at full resolution or, when that
        has more than ``max_cells`` cells, pooled (:meth:`pooled`) by the smallest whole factor that fits."""
        if not crop:
            return TernaryMap(_VALUE_OF_RANK[self.ranks], self.spec)
        x0, y0, x1, y1 = self.seen_bounds_m()
        res = self.resolution_m
        c0, r0 = round(x0 / res) - self.ix0, round(y0 / res) - self.iy0
        c1, r1 = round(x1 / res) - self.ix0, round(y1 / res) - self.iy0
        cells = (c1 - c0) * (r1 - r0)
        if max_cells is not None and cells > max_cells:
            f = math.ceil(math.sqrt(cells / max_cells))
            window = GridSpec(res * f, x0, y0, math.ceil((c1 - c0) / f), math.ceil((r1 - r0) / f))
            return TernaryMap(self.pooled(window), window)
        image = _VALUE_OF_RANK[self.ranks[r0:r1, c0:c1]]
        return TernaryMap(image, GridSpec(res, x0, y0, c1 - c0, r1 - r0))

    def pooled(self, window: GridSpec) -> F32:
        """The map resampled onto a coarser ``window``: each window cell is occupied if any map cell whose centre
        falls in it is, else free if any is, else unknown (:func:`mcnkit.grid.pool_to_window`'s rule)."""
        ranks = _pool(self.ranks, self.ix0, self.iy0, self.resolution_m, window.origin_x_m, window.origin_y_m,
                      window.resolution_m, window.height, window.width)
        return _VALUE_OF_RANK[ranks]
