"""The paper's map encodings and map resizing.

* probabilities → ternary image: occupied 1.0 if p > 0.5, unknown 0.5 if p = 0.5, free 0.0 if p < 0.5;
* ternary image → unknown mask: 1.0 where unknown, else 0.0;
* (image, mask) is the 2-channel network input; the network's 2-channel output goes back to ternary by
  "unknown if mask' ≥ 0.5, else occupied if image' ≥ 0.5, else free" (the paper's map encoding).

Resizing (:func:`resize_ternary`) keeps thin walls: when shrinking, each output cell covers a block of
input cells and takes the *highest-priority* label in its block, occupied > free > unknown.  A one-cell
wall therefore survives any reduction, and a block in which the robot saw anything free stays free (what
was observed is never thrown away).  When enlarging, each output cell copies the input cell under its
centre (nearest neighbour).  Non-square maps are padded first (:func:`pad_to_square`) so the aspect
ratio is kept.

Example:
    >>> img = np.array([[0.0, 0.5], [1.0, 0.5]], np.float32)
    >>> ternary_to_network(img)[1].tolist()
    [[0.0, 1.0], [0.0, 1.0]]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec, TernaryMap

__all__ = [
    "SEEN_WINDOW_M",
    "log_odds_to_ternary",
    "map_window",
    "network_to_ternary",
    "pad_to_square",
    "pool_to_window",
    "probabilities_to_ternary",
    "resize_ternary",
    "seen_window",
    "ternary_to_network",
    "unknown_mask",
]

F32 = NDArray[np.float32]

# Priority ranks used when several input cells fall into one output cell.
_RANK_OF_UNKNOWN, _RANK_OF_FREE, _RANK_OF_OCCUPIED = 0, 1, 2
_VALUE_OF_RANK = np.array([UNKNOWN, FREE, OCCUPIED], dtype=np.float32)


def probabilities_to_ternary(p: NDArray[np.floating]) -> F32:
    """The paper's rule: 1.0 where p > 0.5, 0.5 where p == 0.5, 0.0 where p < 0.5."""
    p = np.asarray(p)
    out = np.full(p.shape, UNKNOWN, dtype=np.float32)
    out[p > 0.5] = OCCUPIED
    out[p < 0.5] = FREE
    return out


def log_odds_to_ternary(log_odds: NDArray[np.floating]) -> F32:
    """Same rule on log-odds (p > 0.5 ⇔ l > 0), without computing probabilities."""
    return probabilities_to_ternary(0.5 + 0.5 * np.sign(np.asarray(log_odds)))


def unknown_mask(image: NDArray[np.floating]) -> F32:
    """1.0 where the ternary image is unknown (0.5), else 0.0."""
    return (np.asarray(image) == UNKNOWN).astype(np.float32)


def ternary_to_network(image: NDArray[np.floating]) -> F32:
    """Stacks ``(..., H, W)`` ternary images into network input ``(..., 2, H, W)`` = (image, mask)."""
    image = np.asarray(image, dtype=np.float32)
    return np.stack([image, unknown_mask(image)], axis=-3)


def network_to_ternary(output: NDArray[np.floating]) -> F32:
    """Converts network output ``(..., 2, H, W)`` = (image', mask') to ternary images ``(..., H, W)``."""
    output = np.asarray(output)
    if output.ndim < 3 or output.shape[-3] != 2:
        raise ValueError(f"network output must have 2 channels in axis -3, got shape {output.shape}")
    image, mask = output[..., 0, :, :], output[..., 1, :, :]
    out = np.where(image >= 0.5, OCCUPIED, FREE).astype(np.float32)
    out[mask >= 0.5] = UNKNOWN
    return out


def pad_to_square(image: NDArray[np.floating], fill: float = UNKNOWN) -> F32:
    """Pads an (H, W) image with ``fill`` on the short side, centred, to a square."""
    image = np.asarray(image, dtype=np.float32)
    h, w = image.shape
    n = max(h, w)
    top, left = (n - h) // 2, (n - w) // 2
    out = np.full((n, n), fill, dtype=np.float32)
    out[top : top + h, left : left + w] = image
    return out


def _ranks(image: F32) -> NDArray[np.int8]:
    ranks = np.full(image.shape, _RANK_OF_UNKNOWN, dtype=np.int8)
    ranks[image == FREE] = _RANK_OF_FREE
    ranks[image == OCCUPIED] = _RANK_OF_OCCUPIED
    return ranks


def _resize_axis(ranks: NDArray[np.int8], size: int, axis: int) -> NDArray[np.int8]:
    n = ranks.shape[axis]
    if n == size:
        return ranks
    if n > size:  # shrink: max-rank over blocks [floor(k n / size), floor((k+1) n / size))
        starts = (np.arange(size) * n) // size
        return np.maximum.reduceat(ranks, starts, axis=axis)
    centres = ((np.arange(size) + 0.5) * n / size).astype(np.int64)  # enlarge: nearest neighbour
    return np.take(ranks, np.minimum(centres, n - 1), axis=axis)


def resize_ternary(image: NDArray[np.floating], size: int | tuple[int, int] = 64) -> F32:
    """Resizes a ternary (H, W) image to ``size`` keeping thin walls (priority occupied > free > unknown).

    Pad non-square maps with :func:`pad_to_square` first if the aspect ratio must be kept.
    """
    image = np.asarray(image, dtype=np.float32)
    if image.ndim != 2:
        raise ValueError(f"resize_ternary takes one (H, W) image, got shape {image.shape}")
    out_h, out_w = (size, size) if isinstance(size, int) else size
    ranks = _resize_axis(_resize_axis(_ranks(image), out_h, 0), out_w, 1)
    return _VALUE_OF_RANK[ranks]


def map_window(bounds_m: tuple[float, float, float, float], size: int, margin_m: float = 0.0,
               min_resolution_m: float = 0.0) -> GridSpec:
    """The paper's window: the bounds ``(x0, y0, x1, y1)`` plus a margin, padded square (centred), on ``size``²
    cells (at least ``min_resolution_m`` each: never finer than the map)."""
    x0, y0, x1, y1 = bounds_m
    side_m = max(x1 - x0, y1 - y0) + 2 * margin_m
    res = max(side_m / size, min_resolution_m)
    half = size * res / 2
    return GridSpec(res, (x0 + x1) / 2 - half, (y0 + y1) / 2 - half, size, size)


SEEN_WINDOW_M: tuple[float, float, float] = (2.0, 8.0, 30.0)
"""The explorer's window by default, ``(margin_m, min_side_m, max_side_m)`` of :func:`seen_window`: the defaults of
``mcnkit explore`` (:class:`mcnkit.explore.config.GainConfig`) and the frame of the ``houseexpo-seen`` pairs."""


def seen_window(bounds_m: tuple[float, float, float, float], size: int, margin_m: float, min_side_m: float,
                max_side_m: float, min_resolution_m: float = 0.0,
                centre_xy_m: tuple[float, float] | None = None) -> GridSpec:
    """The window an explorer completes while the building's extent is unknown: the seen bounds
    ``(x0, y0, x1, y1)`` plus ``margin_m``, at least ``min_side_m`` wide, padded square on ``size``² cells (never
    finer than ``min_resolution_m``); wider than ``max_side_m``: a square of that side centred on ``centre_xy_m``
    (the robot; the bounds' centre without it).  Training pairs built on this window
    (:class:`mcnkit.datasets.PairConfig` ``seen_window``) show a net the maps it completes while exploring."""
    x0, y0, x1, y1 = bounds_m
    extent = max(x1 - x0, y1 - y0)
    margin = max(margin_m, (min_side_m - extent) / 2)
    if extent + 2 * margin > max_side_m:
        cx, cy = ((x0 + x1) / 2, (y0 + y1) / 2) if centre_xy_m is None else centre_xy_m
        half = max_side_m / 2
        return map_window((cx - half, cy - half, cx + half, cy + half), size, 0.0, min_resolution_m)
    return map_window(bounds_m, size, margin, min_resolution_m)


def pool_to_window(ternary: TernaryMap, window: GridSpec, outside: float = UNKNOWN) -> F32:
    """A placed ternary map resampled onto another grid ``window`` (both in metres): each window cell takes the
    highest-priority label (occupied > free > unknown) of the map cells whose centres fall in it; window cells
    that no map cell reaches get ``outside`` (e.g. ``OCCUPIED`` for a floor plan's exterior)."""
    if ternary.spec is None:
        raise ValueError("pool_to_window needs a map placed in the world (TernaryMap.spec)")
    spec = ternary.spec
    xs = spec.origin_x_m + (np.arange(spec.width) + 0.5) * spec.resolution_m
    ys = spec.origin_y_m + (np.arange(spec.height) + 0.5) * spec.resolution_m
    cols = np.floor((xs - window.origin_x_m) / window.resolution_m).astype(np.int64)
    rows = np.floor((ys - window.origin_y_m) / window.resolution_m).astype(np.int64)
    col_in = (cols >= 0) & (cols < window.width)
    row_in = (rows >= 0) & (rows < window.height)
    ranks = _ranks(np.asarray(ternary.image, np.float32))[np.ix_(row_in, col_in)]
    out = np.full(window.shape, -1, np.int8)
    rr, cc = np.meshgrid(rows[row_in], cols[col_in], indexing="ij")
    np.maximum.at(out, (rr.ravel(), cc.ravel()), ranks.ravel())
    values = _VALUE_OF_RANK[np.maximum(out, 0)]
    values[out < 0] = outside
    return values
