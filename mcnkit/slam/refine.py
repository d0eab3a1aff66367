"""Offline refinement of a finished trajectory: every scan matched against the map of all the *other* scans.

The filter places each scan against a map built from the scans before it; once the run is over, every scan can
also be checked against the scans that came after it.  :func:`refine_poses` does so in ``passes`` rounds.  In each
round the scans are placed at their current poses and their returns counted per cell; the scans go in blocks of
``block`` consecutive ones, and each block is matched against the cells hit by every scan *outside* it (the whole
map's counts minus the block's own), so no scan is pulled onto its own returns or its immediate neighbours'.  Each
scan then moves by Gauss-Newton on that likelihood field (:func:`mcnkit.slam.likelihood.refine_match`: kept only
if it scores better, and by at most ``max_shift_m``), and only along the directions the scan pins down (the
eigen-directions of its match information, each scaled by its share of the strongest: a scan in a corridor is not
slid along the axis by a flat field's noise).  All blocks of a round see the same poses, so the result
does not depend on the order of the blocks.

Measured with ``benchmarks/studies/reference_consistency.py`` and ``benchmarks/bench_buildings.py`` (see the README):
it lowers the ATE on every Radish building and the MIT CSAIL relations error, and it makes the scans draw thinner
walls; it is not a loop closer (a scan is moved by at most ``max_shift_m`` per round).

Memory stays bounded on large maps: the hit cells are kept as one sorted array (not a dense grid), each return as the
index of its cell, the scans' returns once (thinned as they come), and each block's likelihood field covers only the
block's reach.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

from mcnkit.slam.correlative import LikelihoodGrid, likelihood_grid, thin_points
from mcnkit.slam.likelihood import refine_match
from mcnkit.slam.proposal import match_information

__all__ = ["REFINE_RANGE_M", "refine_poses"]

F64 = NDArray[np.float64]

REFINE_RANGE_M = 20.0
"""Returns farther than this are left out of the refinement: past 20 m a 0.5° beam spacing spreads neighbouring
end points by more than 0.17 m, 3.5 σ of the likelihood field's 0.05 m."""


def _pinned_down(grid: LikelihoodGrid, points_base: F64, old: F64, new: F64) -> F64:
    """The move ``old`` -> ``new`` kept only along the directions the scan pins down: each eigen-direction of the
    translation block of the match information scaled by its share of the strongest one (along a corridor's axis,
    ~0: a scan there is not slid along the corridor by a flat field's numerical noise)."""
    info = match_information(grid, points_base, new, 1.0)
    vals, vecs = np.linalg.eigh(info[:2, :2])
    if vals[-1] <= 0:
        return np.asarray(old, np.float64).copy()
    shift = vecs @ (np.clip(vals / vals[-1], 0.0, 1.0) * (vecs.T @ (new[:2] - old[:2])))
    return np.array([old[0] + shift[0], old[1] + shift[1], new[2]])


def _cells(poses: F64, owner: NDArray[np.int32], bx: F64, by: F64, resolution_m: float,
           chunk: int = 65536) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The cell (column, row) of every return placed at its scan's pose, computed a chunk at a time so that the
    world-frame coordinates of all returns never exist at once."""
    ix = np.empty(len(owner), np.int64)
    iy = np.empty(len(owner), np.int64)
    cos, sin = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    for a in range(0, len(owner), chunk):
        o, x, y = owner[a : a + chunk], bx[a : a + chunk], by[a : a + chunk]
        c, s = cos[o], sin[o]
        ix[a : a + chunk] = np.floor((poses[o, 0] + c * x - s * y) / resolution_m)
        iy[a : a + chunk] = np.floor((poses[o, 1] + s * x + c * y) / resolution_m)
    return ix, iy


def refine_poses(poses: F64, returns_base: Iterable[F64], resolution_m: float, *, passes: int = 3, block: int = 7,
                 sigma_m: float = 0.05, max_shift_m: float = 0.3) -> F64:
    """The poses (N, 3) moved, scan by scan, onto the likelihood field of the other scans' returns (see the module).

    Args:
        poses: one base pose per scan, in log order.
        returns_base: per scan, its returns (M, 2) in the base frame (M may be 0); any iterable (a generator keeps
            only the thinned returns in memory).
        resolution_m: cell size of the likelihood field.
        passes, block, sigma_m, max_shift_m: rounds, scans left out together, field width, largest move per round.
    """
    poses = np.array(poses, dtype=np.float64, copy=True)
    n = len(poses)
    # one return per cell and scan: a dense scan's neighbouring beams add memory, not information (thinned as the
    # scans come, so a generator's raw returns never all exist at once)
    thinned = [thin_points(np.asarray(r, np.float64).reshape(-1, 2), resolution_m) for r in returns_base]
    if n != len(thinned):
        raise ValueError(f"{n} poses but {len(thinned)} scans")
    sizes = np.array([len(r) for r in thinned], dtype=np.int64)
    if n < 2 * block or sizes.sum() == 0:
        return poses
    owner = np.repeat(np.arange(n, dtype=np.int32), sizes)
    base = np.concatenate(thinned)  # (M, 2): scan k's returns are rows bounds[k]:bounds[k + 1]
    del thinned
    bounds = np.r_[0, np.cumsum(sizes)]
    bx, by = base[:, 0], base[:, 1]
    reach = float(np.sqrt((bx**2 + by**2).max())) + max_shift_m + 1.0
    for _ in range(passes):
        ix, iy = _cells(poses, owner, bx, by, resolution_m)
        x0, y0 = int(ix.min()), int(iy.min())
        height = int(iy.max()) - y0 + 1
        key = ix  # in place: each return's cell as its index on a (width, height) grid
        key -= x0
        key *= height
        iy -= y0
        key += iy
        del ix, iy
        cells, counts = np.unique(key, return_counts=True)  # the hit cells, sorted, and their returns
        centres = np.asarray((np.column_stack([cells // height + x0, cells % height + y0]) + 0.5) * resolution_m, np.float64)
        moved = poses.copy()
        starts = np.searchsorted(owner, np.arange(0, n, block))
        for b, b0 in enumerate(range(0, n, block)):
            b1 = min(b0 + block, n)
            lo, hi = starts[b], (starts[b + 1] if b + 1 < len(starts) else len(owner))
            own_cells, own_counts = np.unique(key[lo:hi], return_counts=True)
            own = np.searchsorted(cells, own_cells)
            others = np.ones(len(cells), bool)
            others[own[counts[own] == own_counts]] = False  # cells only this block hit
            x_lo, y_lo = poses[b0:b1, :2].min(axis=0) - reach
            x_hi, y_hi = poses[b0:b1, :2].max(axis=0) + reach
            others &= (centres[:, 0] >= x_lo) & (centres[:, 0] <= x_hi) & (centres[:, 1] >= y_lo) & (centres[:, 1] <= y_hi)
            if np.count_nonzero(others) < 50:
                continue
            grid = likelihood_grid(centres[others], resolution_m, sigma_m, 1.0, depth=0)
            for k in range(b0, b1):
                if sizes[k] >= 10:
                    points = base[bounds[k] : bounds[k + 1]]
                    found = refine_match(grid, points, poses[k], max_shift_m).pose
                    moved[k] = _pinned_down(grid, points, poses[k], found)
        poses = moved
    return poses
