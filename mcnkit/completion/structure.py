"""Is a completed map shaped like a house?  Two figures that tell houses from blobs and from noise.

- :func:`free_regions`: the number of 4-connected regions of free cells, specks under ``min_cells`` cells
  ignored.  A house's free space is one region (rooms joined by doors); per-cell noise breaks it into many.
- :func:`roughness`: free/non-free cell edges (4-neighbours) per √(free cells).  For a fixed free area it grows
  with the length of the boundary: smooth blobs without interior walls score low, salt-and-pepper noise high;
  it is compared with the true maps' value.

Example:
    >>> room = np.ones((8, 8), np.float32); room[2:6, 2:6] = 0.0      # a 4 × 4 free room in occupied cells
    >>> int(free_regions(room)), float(roughness(room))
    (1, 4.0)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from mcnkit.types import FREE

__all__ = ["free_regions", "roughness", "separating_walls"]

_FOUR = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool)


def free_regions(maps: NDArray[np.floating], min_cells: int = 4) -> NDArray[np.int64]:
    """Per map of ``(..., H, W)`` ternary maps, its 4-connected free regions of at least ``min_cells`` cells."""
    m = np.asarray(maps)
    flat = m.reshape(-1, *m.shape[-2:])
    out = np.empty(len(flat), np.int64)
    for i, one in enumerate(flat):
        labels, n = ndimage.label(one == FREE, structure=_FOUR)
        sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
        out[i] = int((sizes >= min_cells).sum())
    return out.reshape(m.shape[:-2])


def roughness(maps: NDArray[np.floating]) -> NDArray[np.float64]:
    """Per map of ``(..., H, W)`` ternary maps, free/non-free 4-neighbour edges per √(free cells) (NaN: no free
    cell)."""
    free = np.asarray(maps) == FREE
    edges = (free[..., 1:, :] != free[..., :-1, :]).sum(axis=(-2, -1)) + (free[..., :, 1:] != free[..., :, :-1]).sum(
        axis=(-2, -1)
    )
    n = free.sum(axis=(-2, -1)).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, edges / np.sqrt(n), np.nan)


def separating_walls(maps: NDArray[np.floating], editable: NDArray[np.bool_], min_cells: int = 4) -> NDArray[np.bool_]:
    """Per map of ``(N, H, W)`` ternary maps, the ``editable`` occupied cells that wall a free region off from the
    largest one: within one cell of a smaller region (of at least ``min_cells``) and two cells of another region.

    Where a completion's free space falls apart, these are the cells a door could open; a map whose free space
    is one region has none.
    """
    m = np.asarray(maps)
    out = np.zeros(m.shape, bool)
    ring = np.ones((3, 3), bool)
    for i, one in enumerate(m):
        labels, n = ndimage.label(one == FREE, structure=_FOUR)
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        sizes[0] = 0
        regions = np.flatnonzero(sizes >= min_cells)
        if len(regions) < 2:
            continue
        largest = regions[np.argmax(sizes[regions])]
        cut_off = np.isin(labels, regions[regions != largest])
        others = (labels > 0) & ~cut_off
        near_cut = ndimage.binary_dilation(cut_off, structure=ring)
        near_others = ndimage.binary_dilation(others, structure=ring, iterations=2)
        out[i] = (one != FREE) & editable[i] & near_cut & near_others
    return out
