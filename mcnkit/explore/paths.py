"""Shortest paths on the known-free planning grid: scikit-image's ``MCP_Geometric`` (Dijkstra, 8-connected) from the
robot over the cells the robot fits in, with the simulator's cost that grows near walls.

A cell is traversable when it is known free and its clearance (distance to the nearest *occupied* cell; unknown
space is no obstacle for it, the 360° scan sees the robot's surroundings) exceeds the robot radius plus the margin.
One Dijkstra from the robot gives the cost of every reachable cell (:class:`CostField`); a path to any of them is a
traceback.

Example:
    >>> field = cost_field(image, grid, np.array([1.0, 2.0]), robot_radius_m=0.2, margin_m=0.1)  # doctest: +SKIP
    >>> field.path_to(np.array([10, 12])).shape                                                  # doctest: +SKIP
    (23, 2)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from skimage.graph import MCP_Geometric

from mcnkit.types import FREE, OCCUPIED, GridSpec

__all__ = ["CostField", "cost_field", "mark_contacts", "traversable_cells"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

_SNAP_M = 0.6
"""A robot that stands on a cell that is not traversable (it drifted close to a wall) starts its paths from the
nearest traversable cell within this distance."""


def mark_contacts(image: NDArray[np.floating], grid: GridSpec, contacts_xy_m: F64) -> NDArray[np.floating]:
    """``image`` (H, W) with the cells of ``contacts_xy_m`` (N, 2) made occupied: where the robot touched a wall its
    map does not show (a bumper's obstacles in a costmap), so paths keep the robot's radius from them."""
    contacts = np.asarray(contacts_xy_m, np.float64).reshape(-1, 2)
    if len(contacts) == 0:
        return image
    rc = grid.world_to_cell(contacts)
    rc = rc[grid.contains(rc)]
    out = np.array(image, copy=True)
    out[rc[:, 0], rc[:, 1]] = OCCUPIED
    return out


def traversable_cells(image: NDArray[np.floating], resolution_m: float, robot_radius_m: float,
                      margin_m: float) -> tuple[BoolArray, F64]:
    """Known-free cells (H, W) whose clearance to occupied cells exceeds ``robot_radius_m + margin_m``, and the
    clearance (H, W) in metres."""
    clearance = ndimage.distance_transform_edt(image != OCCUPIED) * resolution_m
    return (image == FREE) & (clearance > robot_radius_m + margin_m), clearance


@dataclass(frozen=True)
class CostField:
    """The path cost from the robot to every cell of the planning grid (``inf`` where unreachable)."""

    grid: GridSpec
    traversable: BoolArray
    """(H, W) cells the robot fits in."""
    cost_m: F64
    """(H, W) accumulated path cost from the start [m of path, longer near walls]; ``inf`` where unreachable."""
    start: tuple[int, int] | None
    """The start cell (row, col); None when no traversable cell is near the robot."""
    _mcp: MCP_Geometric | None
    _step: F64 | None = None

    def path_to(self, cell: I64) -> F64:
        """The path (P, 2) in metres from the start to a reachable ``cell`` (row, col)."""
        if self._mcp is None or not np.isfinite(self.cost_m[cell[0], cell[1]]):
            raise ValueError(f"cell {tuple(cell)} is not reachable")
        rc = np.asarray(self._mcp.traceback((int(cell[0]), int(cell[1]))), np.int64)
        return self.grid.cell_to_world(rc)

    def costs_between(self, cells: I64) -> F64:
        """(N, N) path costs [m] between reachable ``cells`` (N, 2) (row, col), with the same step costs as the
        robot's (one Dijkstra from each, stopped once it reached all the others)."""
        cells = np.asarray(cells, np.int64).reshape(-1, 2)
        out = np.zeros((len(cells), len(cells)))
        if self._step is None or len(cells) < 2:
            return out
        targets = [(int(r), int(c)) for r, c in cells]
        for i, start in enumerate(targets):
            costs, _ = MCP_Geometric(self._step).find_costs([start], targets, find_all_ends=True)
            out[i] = costs[cells[:, 0], cells[:, 1]] * self.grid.resolution_m
        return np.minimum(out, out.T)  # the two directions of one path; Dijkstra's ends agree up to rounding


def _snap(traversable: BoolArray, cell: I64, resolution_m: float) -> tuple[int, int] | None:
    """``cell`` when traversable, else the nearest traversable cell within :data:`_SNAP_M`."""
    h, w = traversable.shape
    r, c = int(cell[0]), int(cell[1])
    if 0 <= r < h and 0 <= c < w and traversable[r, c]:
        return r, c
    k = int(np.ceil(_SNAP_M / resolution_m))
    r0, c0 = max(r - k, 0), max(c - k, 0)
    win = traversable[r0 : r + k + 1, c0 : c + k + 1]
    if not win.any():
        return None
    rr, cc = np.nonzero(win)
    d = np.hypot(rr + r0 - r, cc + c0 - c)
    best = int(np.argmin(d))
    if d[best] * resolution_m > _SNAP_M:
        return None
    return int(rr[best] + r0), int(cc[best] + c0)


def cost_field(image: NDArray[np.floating], grid: GridSpec, start_xy_m: F64, robot_radius_m: float,
               margin_m: float, footprint: bool = False) -> CostField:
    """One Dijkstra from the robot at ``start_xy_m`` over the ternary planning map ``image`` (H, W) on ``grid``.

    The step cost is the simulator's: 1 per cell, up to 5 when the clearance is below the robot radius + 0.4 m
    (paths keep to the middle of corridors and doors).  ``footprint``: the cells within ``robot_radius_m`` of the
    robot that the map does not call occupied are traversable too (the robot stands there, so it fits, whatever a
    wall the map draws a cell too thick says): a robot whose map pinches the corridor around it is not closed in."""
    res = grid.resolution_m
    traversable, clearance = traversable_cells(image, res, robot_radius_m, margin_m)
    robot = grid.world_to_cell(np.asarray(start_xy_m, np.float64))
    if footprint:  # only the cells of the robot's disc are looked at
        r = int(np.ceil(robot_radius_m / res))
        r0, c0 = max(int(robot[0]) - r, 0), max(int(robot[1]) - r, 0)
        r1, c1 = min(int(robot[0]) + r + 1, grid.shape[0]), min(int(robot[1]) + r + 1, grid.shape[1])
        rows, cols = np.ogrid[r0:r1, c0:c1]
        under = np.hypot(rows - robot[0], cols - robot[1]) * res <= robot_radius_m
        traversable = traversable.copy()
        traversable[r0:r1, c0:c1] |= under & (image[r0:r1, c0:c1] != OCCUPIED)
    start = _snap(traversable, robot, res)
    if start is None:
        return CostField(grid, traversable, np.full(grid.shape, np.inf), None, None)
    pref = robot_radius_m + 0.4
    step = np.where(traversable, 1.0 + 4.0 * np.clip((pref - clearance) / 0.4, 0.0, 1.0), np.inf)
    mcp = MCP_Geometric(step)
    costs, _ = mcp.find_costs([start])
    costs = np.where(np.isfinite(costs), costs * res, np.inf)
    return CostField(grid, traversable, costs, start, mcp, step)
