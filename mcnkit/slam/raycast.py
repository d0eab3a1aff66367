"""Ray casting: the occupancy counts of scans seen from known poses (the output map and the lineage maps).

For every scan, the cells a beam passes through get a pass and its end cell a hit; occupancy is
``hits / (hits + passes)`` (unknown where both are zero).  Beams longer than the scanner's range are skipped;
beams longer than the map range clear space up to it and mark no hit (gmapping's maxUrange).

* :func:`cast_scan`: one Bresenham kernel that adds or removes a scan (``sign``) and keeps ranks up to date
  (:class:`~mcnkit.slam.lineage.LineageMap` moves a lineage's map by differences with it);
* :func:`ray_cast_counts`: saturating uint16 counts of many scans on a grid holding all of them;
* :func:`ray_cast_strips`: the same, strip by strip from the top, in bounded memory (campus-sized maps).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numba
import numpy as np
from numpy.typing import NDArray

from mcnkit.types import GridSpec

__all__ = ["cast_scan", "ray_cast_counts", "ray_cast_strips", "scan_end_points"]

F64 = NDArray[np.float64]
I32 = NDArray[np.int32]
U16 = NDArray[np.uint16]


@numba.njit(cache=True, inline="always")
def _rank(hits: int, n: int, occ_thresh: float) -> int:
    """0 unknown (never seen), 1 free, 2 occupied (``hits / n > occ_thresh``)."""
    if n <= 0:
        return 0
    return 2 if hits > occ_thresh * n else 1


@numba.njit(cache=True)
def scan_end_points(
    lx: float, ly: float, lt: float, ranges: NDArray[np.float32], angles: F64, max_range: float, usable: float,
) -> tuple[F64, F64, NDArray[np.bool_]]:
    """End points of the usable beams of one scan from laser pose (lx, ly, lt), and which of them are hits.

    A beam is used when finite, > 0 and ≤ ``max_range``; it is cut at ``usable`` and then marks no hit."""
    n = 0
    for i in range(ranges.shape[0]):
        r = ranges[i]
        if np.isfinite(r) and r > 0 and r <= max_range:
            n += 1
    ex = np.empty(n)
    ey = np.empty(n)
    hit = np.empty(n, np.bool_)
    j = 0
    for i in range(ranges.shape[0]):
        r = float(ranges[i])
        if np.isfinite(r) and r > 0 and r <= max_range:
            d = min(r, usable)
            ex[j] = lx + d * math.cos(lt + angles[i])
            ey[j] = ly + d * math.sin(lt + angles[i])
            hit[j] = r < usable
            j += 1
    return ex, ey, hit


@numba.njit(cache=True)
def cast_scan(
    hits: I32, passes: I32, ranks: NDArray[np.int8], ix0: int, iy0: int, res: float,
    lx: float, ly: float, ex: F64, ey: F64, is_hit: NDArray[np.bool_], sign: int, occ_thresh: float,
) -> None:
    """Bresenham from the laser at (lx, ly) to each end cell: ``sign`` added to passes on the way and to the hit
    cell; the rank of every touched cell is brought up to date."""
    x0 = int(math.floor(lx / res)) - ix0
    y0 = int(math.floor(ly / res)) - iy0
    for k in range(ex.shape[0]):
        x1 = int(math.floor(ex[k] / res)) - ix0
        y1 = int(math.floor(ey[k] / res)) - iy0
        dx, dy = abs(x1 - x0), -abs(y1 - y0)
        stx = 1 if x0 < x1 else -1
        sty = 1 if y0 < y1 else -1
        err = dx + dy
        x, y = x0, y0
        while x != x1 or y != y1:
            passes[y, x] += sign
            ranks[y, x] = _rank(hits[y, x], hits[y, x] + passes[y, x], occ_thresh)
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x += stx
            if e2 <= dx:
                err += dx
                y += sty
        if is_hit[k]:
            hits[y1, x1] += sign
            ranks[y1, x1] = _rank(hits[y1, x1], hits[y1, x1] + passes[y1, x1], occ_thresh)


@numba.njit(cache=True)
def _cast_strip(hits: U16, passes: U16, ix0: int, row0: int, res: float, lx: float, ly: float, ex: F64, ey: F64,
                is_hit: NDArray[np.bool_], iy_lo: int) -> None:
    """Saturating uint16 counts of one scan, no ranks (half the memory of :func:`cast_scan`'s int32), into a strip
    holding global cell rows ``row0 .. row0 + H - 1`` only (``iy_lo``: the grid's first cell row); cells outside
    the strip are walked over but not stored.  A whole grid is the strip with ``row0 = 0``."""
    h = hits.shape[0]
    x0 = int(math.floor(lx / res)) - ix0
    y0 = int(math.floor(ly / res)) - iy_lo
    for k in range(ex.shape[0]):
        x1 = int(math.floor(ex[k] / res)) - ix0
        y1 = int(math.floor(ey[k] / res)) - iy_lo
        if max(y0, y1) < row0 or min(y0, y1) >= row0 + h:
            continue
        dx, dy = abs(x1 - x0), -abs(y1 - y0)
        stx = 1 if x0 < x1 else -1
        sty = 1 if y0 < y1 else -1
        err = dx + dy
        x, y = x0, y0
        while x != x1 or y != y1:
            r = y - row0
            if 0 <= r < h and passes[r, x] < 65535:
                passes[r, x] += 1
            e2 = 2 * err
            if e2 >= dy:
                err += dy
                x += stx
            if e2 <= dx:
                err += dx
                y += sty
        r = y1 - row0
        if is_hit[k] and 0 <= r < h and hits[r, x1] < 65535:
            hits[r, x1] += 1


def ray_cast_strips(
    laser_poses: F64,
    ranges_m: NDArray[np.floating],
    angles_rad: F64,
    max_range_m: float,
    max_usable_range_m: float,
    resolution_m: float,
    strip_cells: int = 512,
    margin_m: float = 1.0,
) -> tuple[GridSpec, Iterator[tuple[int, U16, U16]]]:
    """:func:`ray_cast_counts` in horizontal strips, from the top (highest y) down: the grid, and an iterator of
    ``(first row, hits, passes)`` with at most ``strip_cells`` rows each.  Memory stays that of one strip
    whatever the map's size (a campus-sized map is ~25 M cells); every strip walks every ray once."""
    r = np.asarray(ranges_m)
    lasers = np.asarray(laser_poses, np.float64)
    ends = [scan_end_points(lx, ly, lt, r[k], angles_rad, max_range_m, max_usable_range_m)
            for k, (lx, ly, lt) in enumerate(lasers)]
    allx = np.concatenate([e[0] for e in ends] + [lasers[:, 0]])
    ally = np.concatenate([e[1] for e in ends] + [lasers[:, 1]])
    ix0 = math.floor((allx.min() - margin_m) / resolution_m)
    iy0 = math.floor((ally.min() - margin_m) / resolution_m)
    width = math.floor((allx.max() + margin_m) / resolution_m) - ix0 + 1
    height = math.floor((ally.max() + margin_m) / resolution_m) - iy0 + 1
    spec = GridSpec(resolution_m, ix0 * resolution_m, iy0 * resolution_m, width, height)

    def strips() -> Iterator[tuple[int, U16, U16]]:
        for top in range(height, 0, -strip_cells):
            row0 = max(0, top - strip_cells)
            hits = np.zeros((top - row0, width), np.uint16)
            passes = np.zeros((top - row0, width), np.uint16)
            for (lx, ly, _lt), (ex, ey, hit) in zip(lasers, ends, strict=True):
                _cast_strip(hits, passes, ix0, row0, resolution_m, lx, ly, ex, ey, hit, iy0)
            yield row0, hits, passes

    return spec, strips()


def ray_cast_counts(
    laser_poses: F64,
    ranges_m: NDArray[np.floating],
    angles_rad: F64,
    max_range_m: float,
    max_usable_range_m: float,
    resolution_m: float,
    margin_m: float = 1.0,
) -> tuple[GridSpec, U16, U16]:
    """Hit and pass counts (uint16, saturating) of scans (K, M) from laser poses (K, 3), on a grid holding all.

    Beams that are not finite, zero, or longer than ``max_range_m`` are skipped; beams longer than
    ``max_usable_range_m`` clear space up to that range and mark no hit (gmapping's rule).  The grid covers the
    lasers and their (clipped) end points, so its size is bounded by the path and the usable range.
    """
    spec, strips = ray_cast_strips(laser_poses, ranges_m, angles_rad, max_range_m, max_usable_range_m, resolution_m,
                                   strip_cells=2**31 - 1, margin_m=margin_m)
    _row0, hits, passes = next(strips)  # the whole grid is the one strip at row 0
    return spec, hits, passes
