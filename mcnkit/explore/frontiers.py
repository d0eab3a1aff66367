"""Frontiers (Yamauchi 1997) on the planning map and the viewpoints from which to look past them.

The planning map (:func:`planning_map`) is the SLAM map with its *thin* unknown cells (those in no 3 × 3 square of
unknown cells: the stripes between beams far from the robot, the holes in a wall between two beams' hits) counted
free when no wall is there, so that paths cross them and they make no frontier.  A frontier cell is a free cell
8-adjacent to the remaining unknown space, of which regions smaller than ``unknown_min_m2`` make none.  Frontier
cells are grouped into
8-connected clusters, clusters shorter than ``frontier_min_m`` dropped, and long clusters cut into segments by a
``segment_m`` tiling, so a long frontier along an open area offers several places to look from.

A segment's viewpoint is the reachable cell nearest to the segment (within ``reach_m``; each cell serves the segment
of its nearest frontier cell), the cheapest to reach among equally near ones: a frontier cell itself where the robot
fits there, else the closest place to it.  A segment without one is unreachable and dropped, as are
viewpoints near a blacklisted place (a goal the robot could not get to or that did not remove its frontier).

Example:
    >>> f = find_frontiers(image, grid, ExploreConfig())                     # doctest: +SKIP
    >>> v = viewpoints(f, field, ExploreConfig(), blacklist_xy_m=np.zeros((0, 2)))  # doctest: +SKIP
    >>> v.xy_m[np.argmin(v.cost_m)]                                          # the nearest frontier  # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from mcnkit.explore.config import ExploreConfig
from mcnkit.explore.paths import CostField
from mcnkit.types import FREE, UNKNOWN, GridSpec

__all__ = ["Frontiers", "Viewpoints", "find_frontiers", "planning_map", "viewpoints"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
_EIGHT = np.ones((3, 3), bool)


@dataclass(frozen=True)
class Frontiers:
    """Frontier cells of a planning map and the segment each belongs to."""

    grid: GridSpec
    cells: I64
    """(N, 2) frontier cells (row, col)."""
    segment: I64
    """(N,) segment index of each cell, 0 .. ``n_segments`` − 1."""
    n_segments: int

    @property
    def mask(self) -> BoolArray:
        """(H, W) True on frontier cells."""
        out = np.zeros(self.grid.shape, bool)
        out[self.cells[:, 0], self.cells[:, 1]] = True
        return out

    def xy_m(self) -> F64:
        """(N, 2) centres of the frontier cells in metres."""
        return self.grid.cell_to_world(self.cells)


def planning_map(image: NDArray[np.floating]) -> NDArray[np.float32]:
    """The ternary SLAM map (H, W) with its thin unknown cells (in no 3 × 3 square of unknown cells) made free."""
    unknown = image == UNKNOWN
    thin = unknown & ~ndimage.binary_opening(unknown, _EIGHT)
    return np.where(thin, FREE, image).astype(np.float32)


def find_frontiers(image: NDArray[np.floating], grid: GridSpec, config: ExploreConfig) -> Frontiers:
    """The frontier segments of a planning map ``image`` (H, W; :func:`planning_map`) on ``grid`` (see the module
    docstring)."""
    res = grid.resolution_m
    unknown = image == UNKNOWN
    labels, n = ndimage.label(unknown, _EIGHT)
    if n:
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        big = sizes >= config.unknown_min_m2 / res**2
        big[0] = False
        unknown = big[labels]
    frontier = (image == FREE) & ndimage.binary_dilation(unknown, _EIGHT)
    labels, n = ndimage.label(frontier, _EIGHT)
    if n == 0:
        return Frontiers(grid, np.zeros((0, 2), np.int64), np.zeros(0, np.int64), 0)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    keep = sizes >= max(config.frontier_min_m / res, 1.0)
    keep[0] = False
    rr, cc = np.nonzero(keep[labels])
    cluster = labels[rr, cc].astype(np.int64)
    tile = max(int(round(config.segment_m / res)), 1)
    tiles_per_row = grid.width // tile + 1
    key = cluster * (tiles_per_row * (grid.height // tile + 1)) + (rr // tile) * tiles_per_row + cc // tile
    _, segment = np.unique(key, return_inverse=True)
    return Frontiers(grid, np.stack([rr, cc], 1).astype(np.int64), segment.astype(np.int64),
                     int(segment.max()) + 1 if len(segment) else 0)


@dataclass(frozen=True)
class Viewpoints:
    """One place per reachable frontier segment to look past it from, with its path cost."""

    segment: I64
    """(V,) the frontier segment each viewpoint serves."""
    cells: I64
    """(V, 2) viewpoint cells (row, col) on the planning grid."""
    xy_m: F64
    """(V, 2) viewpoint positions [m]."""
    cost_m: F64
    """(V,) path cost from the robot [m]."""
    size: I64
    """(V,) frontier cells in the segment."""

    def __len__(self) -> int:
        return len(self.segment)


def viewpoints(frontiers: Frontiers, field: CostField, config: ExploreConfig,
               blacklist_xy_m: F64) -> Viewpoints:
    """For each frontier segment, the reachable cell nearest to it (within ``reach_m``; the cheapest to reach among
    equally near ones); segments without one, and viewpoints within ``blacklist_m`` of a blacklisted place, are
    dropped.  Cheapest first."""
    grid = frontiers.grid
    empty = Viewpoints(np.zeros(0, np.int64), np.zeros((0, 2), np.int64), np.zeros((0, 2)), np.zeros(0),
                       np.zeros(0, np.int64))
    if frontiers.n_segments == 0:
        return empty
    not_frontier = np.ones(grid.shape, bool)
    not_frontier[frontiers.cells[:, 0], frontiers.cells[:, 1]] = False
    dist, (nr, nc) = ndimage.distance_transform_edt(not_frontier, return_indices=True)
    seg_map = np.full(grid.shape, -1, np.int64)
    seg_map[frontiers.cells[:, 0], frontiers.cells[:, 1]] = frontiers.segment
    near = np.isfinite(field.cost_m) & (dist * grid.resolution_m <= config.reach_m)
    rr, cc = np.nonzero(near)
    if len(rr) == 0:
        return empty
    seg = seg_map[nr[rr, cc], nc[rr, cc]]
    cost = field.cost_m[rr, cc]
    order = np.lexsort((cost, dist[rr, cc], seg))  # by segment, then nearest the frontier, then cheapest
    first = order[np.r_[True, seg[order][1:] != seg[order][:-1]]]
    cells = np.stack([rr[first], cc[first]], 1).astype(np.int64)
    xy = grid.cell_to_world(cells)
    keep = np.ones(len(first), bool)
    if len(blacklist_xy_m):
        d = np.hypot(*(xy[:, None, :] - np.asarray(blacklist_xy_m)[None, :, :]).transpose(2, 0, 1))
        keep = d.min(axis=1) > config.blacklist_m
    by_cost = np.argsort(cost[first][keep], kind="stable")
    sizes = np.bincount(frontiers.segment, minlength=frontiers.n_segments)
    segs = seg[first][keep][by_cost]
    return Viewpoints(segs, cells[keep][by_cost], xy[keep][by_cost], cost[first][keep][by_cost],
                      sizes[segs].astype(np.int64))
