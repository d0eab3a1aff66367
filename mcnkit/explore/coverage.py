"""Coverage: the share of the reachable free space that the robot's sensor has seen, measured on the ground truth.

*Seen* is what a scan from the true laser pose can see: the free cells that rays (``coverage_rays`` over 360°,
finer than the lidar's beams so that far cells between two beams are not missed) cross before the first wall,
up to the lidar's range.  The *reachable free space* is every free cell a scan can see from some place the robot
fits in and can get to (the safe region, :func:`mcnkit.sim.safe_region`, with the planner's margin), sampled on a
``coverage_lattice_m`` lattice plus the start: space behind a gap too narrow for the robot, or never in sight of
one, does not count against it.  Both planners are measured by the same numbers, independent of their SLAM maps.

Example:
    >>> reach = reachable_free(raster, safe, start_xy_m, range_m=8.0, rays=720, lattice_m=0.5)  # doctest: +SKIP
    >>> seen = np.zeros_like(reach); mark_seen(raster.free, raster.grid, seen, laser_xy_m, 8.0, 720)  # doctest: +SKIP
    >>> (seen & reach).sum() / reach.sum()                                                     # doctest: +SKIP
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mcnkit.explore.rays import cast_visibility
from mcnkit.sim import PlanRaster
from mcnkit.types import GridSpec

__all__ = ["mark_seen", "reachable_free"]

F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


def mark_seen(free: BoolArray, grid: GridSpec, seen: BoolArray, xy_m: NDArray[np.floating], range_m: float,
              rays: int) -> None:
    """Marks in ``seen`` (H, W), in place, the free cells a scan from each position ``xy_m`` (N, 2) sees."""
    origins = grid.world_to_cells_xy(np.asarray(xy_m, np.float64).reshape(-1, 2))
    visible = np.zeros_like(seen)
    cast_visibility(~free[None], None, origins, rays, range_m / grid.resolution_m, mask=visible)
    seen |= visible & free


def reachable_free(raster: PlanRaster, safe: BoolArray, start_xy_m: NDArray[np.floating], range_m: float, rays: int,
                   lattice_m: float, max_points: int = 2000) -> BoolArray:
    """(H, W) the free cells a scan sees from the safe cells on a ``lattice_m`` lattice (coarser where that would
    be more than ``max_points`` places: a large building), and from the start."""
    step = max(int(round(lattice_m / raster.grid.resolution_m)), 1)
    step = max(step, int(np.ceil(np.sqrt(safe.sum() / max_points))))
    lattice = np.zeros_like(safe)
    lattice[::step, ::step] = True
    rc = np.argwhere(safe & lattice)
    xy = np.concatenate([raster.grid.cell_to_world(rc), np.asarray(start_xy_m, np.float64).reshape(1, 2)])
    out = np.zeros_like(raster.free)
    mark_seen(raster.free, raster.grid, out, xy, range_m, rays)
    return out
