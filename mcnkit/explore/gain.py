"""The information a scan from a viewpoint is expected to bring, from K sampled completions of the map.

Each sample is a whole plausible house: a scan from viewpoint ``v`` in sample ``k`` sees the cells that rays from
``v`` cross before they hit a wall *of that sample* (:func:`visible_gains`, rays marched half a cell at a time up
to the sensor range, the wall cell itself seen: :func:`mcnkit.explore.rays.cast_visibility`).  What it is worth is the sum of a per-cell weight over the cells
it sees, averaged over the samples; the weights (:func:`cell_weights`) are

* ``unknown``: the cell's area where the SLAM map does not know it (expected visible unknown area, m²);
* ``disagreement``: that area times 4·p·(1 − p), p the share of samples occupied there (MapEx's variance weighting:
  cells the samples agree on count little);
* ``observed``: the unknown area again, but seen through the SLAM map's own known walls (unknown space
  transparent): the information gain without any prediction, to measure what the samples add;
* ``consensus``: the unknown area seen through the walls that at least half the samples draw (the mean completion's
  walls, as MapEx casts its rays): a wall one sample imagines alone does not hide what lies behind it;
* ``open``: the unknown area weighted by the share of samples that call it free, seen through the SLAM map's known
  walls only: the samples say how far the house goes, not where its unseen walls stand;
* ``free``: in each sample, the unknown cells that sample calls free, seen through its own walls: the floor a scan
  would add, which is what exploration's coverage counts (its walls and the outside are not).

Seen now or seen later is not the same for every cell: a *pocket* of a sample, unknown space that the sample's
walls close off (a closet, a room behind a door), that one scan from the viewpoint would nearly finish needs no
return trip when seen now, and a trip back from wherever the robot is when left.  :func:`finished_pockets` counts
the area of such pockets once more (``GainConfig.finish_share``), so a predicted closet next to the robot is not
left behind for a larger but farther view, the return trips that lengthen greedy exploration.

A building wider than the completions' window (``GainConfig.window_max_m``) is completed only around the robot;
what a scan would see of the map's unknown space beyond that window is counted too (:func:`beyond_window_gains`),
else every viewpoint past the window would be worth nothing and the robot, once the space around it is seen, would
wander among the last scraps of it instead of driving on to the rest of the building.

The gain is traded against the path cost (:func:`trade_off`): ``gain / (cost + floor)`` (MapEx divides by the
distance) or ``gain · exp(−λ · cost)``.

Example:
    >>> walls = np.zeros((1, 8, 8), bool); walls[0, :, 6] = True
    >>> w = np.ones((8, 8))
    >>> visible_gains(walls, w, np.array([[2.5, 4.5]]), n_beams=64, range_cells=20.0)[0, 0] > 0
    True
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from mcnkit.explore.config import GainConfig
from mcnkit.explore.rays import cast_visibility
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["beyond_window_gains", "cell_weights", "expected_gains", "finished_pockets", "sample_walls", "trade_off",
           "visible_gains", "visible_mask"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
BoolArray = NDArray[np.bool_]

_START_CELLS = 0.75
"""Walls closer than this to the viewpoint (in cells) do not stop its rays: on a coarse window the viewpoint's own
cell may hold a wall fragment next to the free space it stands in."""


def visible_gains(walls: BoolArray, weight: NDArray[np.floating], origins_xy_cells: NDArray[np.floating],
                  n_beams: int, range_cells: float) -> F64:
    """(V, K): for every origin (V, 2) ``[col, row]`` in cells and every sample's walls (K, H, W), the summed
    ``weight`` (H, W) of the cells a scan of ``n_beams`` rays reaching ``range_cells`` sees."""
    return cast_visibility(walls, weight, origins_xy_cells, n_beams, range_cells, _START_CELLS)


def visible_mask(walls: BoolArray, origin_xy_cells: NDArray[np.floating], n_beams: int,
                 range_cells: float) -> BoolArray:
    """(H, W) cells a scan from one origin ``[col, row]`` sees through ``walls`` (H, W)."""
    mask = np.zeros(np.shape(walls), np.bool_)
    cast_visibility(np.asarray(walls)[None], None, origin_xy_cells, n_beams, range_cells, _START_CELLS, mask)
    return mask


def finished_pockets(samples: NDArray[np.floating], partial: NDArray[np.floating], origins_xy_cells: NDArray[np.floating],
                     n_beams: int, range_cells: float, cell_area_m2: float, share: float) -> F64:
    """(V, K): for every origin (V, 2) ``[col, row]`` and sample (K, H, W), the area [m²] of the sample's pockets a
    scan from there would see at least ``share`` of.  A pocket is a 4-connected region of cells unknown in
    ``partial`` and not occupied in the sample that does not touch the window's edge (beyond it the house may go
    on); its cells are seen through the sample's own walls (:func:`visible_mask`)."""
    partial = np.asarray(partial)
    samples = np.asarray(samples)
    origins = np.asarray(origins_xy_cells, np.float64).reshape(-1, 2)
    out = np.zeros((len(origins), len(samples)))
    if share <= 0 or len(origins) == 0:
        return out
    unknown = partial == UNKNOWN
    for k, sample in enumerate(samples):
        walls = sample == OCCUPIED
        labels, n = ndimage.label(unknown & ~walls)
        if n == 0:
            continue
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        closed = np.ones(n + 1, np.bool_)
        closed[0] = False
        closed[np.unique(np.r_[labels[0], labels[-1], labels[:, 0], labels[:, -1]])] = False
        if not closed.any():
            continue
        for v, origin in enumerate(origins):
            seen = np.bincount(labels[visible_mask(walls, origin, n_beams, range_cells)], minlength=n + 1)
            out[v, k] = float(sizes[closed & (seen >= share * sizes)].sum()) * cell_area_m2
    return out


def sample_walls(samples: NDArray[np.floating], partial: NDArray[np.floating], kind: str) -> BoolArray:
    """The walls (K, H, W) the visibility is cast through: each sample's occupied cells, or (K = 1) the SLAM map's
    own occupied cells only (``observed``) or the cells at least half the samples say are occupied (``consensus``)."""
    if kind in ("observed", "open"):
        return (np.asarray(partial) == OCCUPIED)[None]
    if kind == "consensus":
        return ((np.asarray(samples) == OCCUPIED).mean(axis=0) >= 0.5)[None]
    return np.asarray(samples) == OCCUPIED


def cell_weights(samples: NDArray[np.floating], partial: NDArray[np.floating], cell_area_m2: float,
                 kind: str) -> F64:
    """What seeing each cell (H, W) is worth (see the module docstring) [m²]; for ``free`` one map per sample
    (K, H, W), each sample's own free cells."""
    unknown = np.asarray(partial) == UNKNOWN
    if kind == "free":
        return (unknown & (np.asarray(samples) == FREE)) * float(cell_area_m2)
    if kind in ("unknown", "observed", "consensus"):
        return unknown * float(cell_area_m2)
    if kind == "open":
        return unknown * (np.asarray(samples) == FREE).mean(axis=0) * float(cell_area_m2)
    if kind == "disagreement":
        p = (np.asarray(samples) == OCCUPIED).mean(axis=0)
        return unknown * (4.0 * p * (1.0 - p)) * float(cell_area_m2)
    raise ValueError(f"unknown gain {kind!r}")


def expected_gains(samples: NDArray[np.floating], partial: NDArray[np.floating], origins_xy_cells: NDArray[np.floating],
                   config: GainConfig, range_cells: float, cell_area_m2: float) -> F64:
    """(V,) what a scan from each origin ``[col, row]`` is expected to bring [m²], as ``config`` scores it: the
    weighted cells it sees (:func:`cell_weights` through :func:`sample_walls`), plus the pockets it finishes
    (``finish_share``), averaged over the samples, mixed with the ``observed`` gain by ``sample_share``."""
    walls = sample_walls(samples, partial, config.gain)
    weight = cell_weights(samples, partial, cell_area_m2, config.gain)
    if weight.ndim == 3:  # a weight per sample: each sample's cells seen through its own walls
        per_sample = np.concatenate([visible_gains(walls[k : k + 1], weight[k], origins_xy_cells, config.beams,
                                                   range_cells) for k in range(len(walls))], axis=1)
    else:
        per_sample = visible_gains(walls, weight, origins_xy_cells, config.beams, range_cells)
    if config.finish_share > 0:
        per_sample = per_sample + finished_pockets(samples, partial, origins_xy_cells, config.beams, range_cells,
                                                   cell_area_m2, config.finish_share)
    gain = per_sample.mean(axis=1)
    if config.sample_share < 1 and config.gain != "observed":
        plain = visible_gains(sample_walls(samples, partial, "observed"),
                              cell_weights(samples, partial, cell_area_m2, "observed"), origins_xy_cells,
                              config.beams, range_cells)[:, 0]
        gain = config.sample_share * gain + (1.0 - config.sample_share) * plain
    return np.asarray(gain, np.float64)


def beyond_window_gains(outer: NDArray[np.floating], inside: BoolArray, window_gains: F64,
                        origins_xy_cells: NDArray[np.floating], n_beams: int, range_cells: float,
                        cell_area_m2: float) -> F64:
    """(V,) what a scan from each origin ``[col, row]`` is expected to bring beyond the completions' window [m²].

    ``outer`` (H, W) is the SLAM map (ternary) on a grid holding the window, ``inside`` (H, W) marks the window's
    cells on it, ``window_gains`` (V,) are the samples' gains inside it.  Beyond the window no sample says where
    walls stand, so the unknown area a scan would see there through the map's known walls (the ``observed`` gain)
    is scaled by the share of it the samples expect inside the window (the same gain on the window's unknown cells,
    over all viewpoints; at most 1): the two parts of a viewpoint's gain are then in the same units.  Zeros when the
    map has no unknown cell beyond the window (a house the window holds whole)."""
    outer = np.asarray(outer)
    unknown = outer == UNKNOWN
    beyond = unknown & ~inside
    origins = np.asarray(origins_xy_cells, np.float64).reshape(-1, 2)
    if not beyond.any() or len(origins) == 0:
        return np.zeros(len(origins))
    walls = (outer == OCCUPIED)[None]
    seen_beyond = visible_gains(walls, beyond * cell_area_m2, origins, n_beams, range_cells)[:, 0]
    seen_inside = visible_gains(walls, (unknown & inside) * cell_area_m2, origins, n_beams, range_cells)[:, 0]
    total_inside = float(seen_inside.sum())
    share = min(1.0, max(0.0, float(np.sum(window_gains)) / total_inside)) if total_inside > 0 else 1.0
    return np.asarray(share * seen_beyond, np.float64)


def trade_off(gain: F64, cost_m: F64, kind: str, cost_lambda_per_m: float, cost_floor_m: float) -> F64:
    """Scores (V,) of gains (V,) at path costs (V,): ``ratio`` = gain / (cost + floor), ``exp`` = gain·e^(−λ·cost)."""
    if kind == "ratio":
        return np.asarray(gain / (cost_m + cost_floor_m), np.float64)
    if kind == "exp":
        return np.asarray(gain * np.exp(-cost_lambda_per_m * cost_m), np.float64)
    raise ValueError(f"unknown trade-off {kind!r}")
