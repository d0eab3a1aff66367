"""Visibility on a grid: rays marched half a cell at a time from origins, stopped by walls (one numba kernel for
the expected gain of a viewpoint and for what the sensor saw).  Wall cells that touch at a corner close the wall
between them, so a slanted wall one cell thick stops a ray as the simulated lidar's beams are stopped."""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["cast_visibility"]

F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@numba.njit(cache=True)
def _cast(walls: NDArray[np.bool_], weight: F64, origins_xy: F64, n_rays: int, range_cells: float, start_cells: float,
          mask: NDArray[np.bool_]) -> F64:
    k_n, h, w = walls.shape
    v_n = origins_xy.shape[0]
    out = np.zeros((v_n, k_n))
    stamp = np.zeros((h, w), np.int64)
    steps = int(range_cells * 2.0)
    marking = mask.shape[0] > 0
    for v in range(v_n):
        ox, oy = origins_xy[v, 0], origins_xy[v, 1]
        for k in range(k_n):
            tag = v * k_n + k + 1
            total = 0.0
            for b in range(n_rays):
                ang = 2.0 * math.pi * b / n_rays
                dx, dy = math.cos(ang), math.sin(ang)
                pr, pc = -1, -1
                for s in range(steps + 1):
                    t = 0.5 * s
                    c = int(math.floor(ox + dx * t))
                    r = int(math.floor(oy + dy * t))
                    if r < 0 or r >= h or c < 0 or c >= w:
                        break
                    if (s > 0 and r != pr and c != pc and walls[k, pr, c] and walls[k, r, pc]
                            and t >= start_cells):
                        break  # between two wall cells that touch at a corner: a slanted wall one cell thick
                    pr, pc = r, c
                    if stamp[r, c] != tag:
                        stamp[r, c] = tag
                        total += weight[r, c]
                        if marking:
                            mask[r, c] = True
                    if walls[k, r, c] and t >= start_cells:
                        break
            out[v, k] = total
    return out


def cast_visibility(walls: BoolArray, weight: NDArray[np.floating] | None, origins_xy_cells: NDArray[np.floating],
                    n_rays: int, range_cells: float, start_cells: float = 0.0,
                    mask: BoolArray | None = None) -> F64:
    """For every origin (V, 2) ``[col, row]`` in cells and every wall layer (K, H, W): the summed ``weight`` (H, W;
    None: none) of the cells seen by ``n_rays`` rays over 360° reaching ``range_cells``, each cell counted once
    (V, K).  A ray stops at the first wall cell (seen itself), or where it passes between two wall cells touching at a
    corner, at least ``start_cells`` from its origin; cells outside the grid end it.  ``mask`` (H, W), when given,
    gets every cell seen marked True, in place."""
    walls = np.ascontiguousarray(walls, dtype=np.bool_)
    if walls.ndim != 3:
        raise ValueError(f"walls must be (K, H, W), got {walls.shape}")
    w = np.zeros(walls.shape[1:]) if weight is None else np.ascontiguousarray(weight, np.float64)
    m = np.zeros((0, 0), np.bool_) if mask is None else mask
    return _cast(walls, w, np.ascontiguousarray(origins_xy_cells, np.float64).reshape(-1, 2), int(n_rays),
                 float(range_cells), float(start_cells), m)
