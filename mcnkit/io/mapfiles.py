"""Occupancy maps as files: ROS ``map_server`` (``.pgm`` + ``.yaml``) and a ``.png`` to look at.

The map is the filter's hit / pass counts: a cell is occupied when ``hits / (hits + passes)`` exceeds the
threshold, free when seen otherwise, unknown when never seen.  :func:`write_map_strips` takes the counts strip by
strip from the top of the map down (:func:`mcnkit.slam.raycast.ray_cast_strips`) and writes the PGM row by row, so a
campus-sized map never sits in memory whole; the PNG is a preview of at most ``preview_cells`` on its long side
(each preview pixel occupied if any of its cells is, else free if any is).

Example:
    >>> spec, strips = ray_cast_strips(poses, ranges, angles, 81.9, 23.0, 0.05)  # doctest: +SKIP
    >>> write_map_strips(Path("out"), spec, strips, occ_thresh=0.25)              # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.types import GridSpec, OccupancyGrid

__all__ = ["PGM_FREE", "PGM_OCCUPIED", "PGM_UNKNOWN", "write_map", "write_map_strips"]

PGM_OCCUPIED, PGM_FREE, PGM_UNKNOWN = 0, 254, 205


def _yaml(out_dir: Path, stem: str, spec: GridSpec) -> None:
    (out_dir / f"{stem}.yaml").write_text(
        f"image: {stem}.pgm\nresolution: {spec.resolution_m:g}\n"
        f"origin: [{spec.origin_x_m:.6f}, {spec.origin_y_m:.6f}, 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
        "free_thresh: 0.196\n"
    )


def _counts_to_pgm(hits: NDArray[np.integer], passes: NDArray[np.integer], occ_thresh: float) -> NDArray[np.uint8]:
    """PGM values of count rows (bottom row first), flipped so the highest y comes first."""
    total = hits.astype(np.uint32) + passes
    img = np.full(hits.shape, PGM_UNKNOWN, np.uint8)
    img[total > 0] = PGM_FREE
    img[(total > 0) & (hits > occ_thresh * total)] = PGM_OCCUPIED
    return img[::-1]


def _pool_rank(img: NDArray[np.uint8], f: int) -> NDArray[np.uint8]:
    """Pools a PGM strip by ``f``: occupied if any cell is, else free if any is, else unknown."""
    h, w = img.shape
    ph, pw = math.ceil(h / f), math.ceil(w / f)
    rank = np.zeros((ph * f, pw * f), np.uint8)  # 0 unknown, 1 free, 2 occupied
    rank[:h, :w] = np.where(img == PGM_OCCUPIED, 2, np.where(img == PGM_FREE, 1, 0))
    pooled = rank.reshape(ph, f, pw, f).max(axis=(1, 3))
    return np.array([PGM_UNKNOWN, PGM_FREE, PGM_OCCUPIED], np.uint8)[pooled]


def write_map_strips(out_dir: Path, spec: GridSpec, strips: Iterable[tuple[int, NDArray[np.integer], NDArray[np.integer]]],
                     occ_thresh: float, stem: str = "map", preview_cells: int = 4096) -> None:
    """Writes ``stem.pgm`` + ``stem.yaml`` + ``stem.png`` from count strips given top strip first."""
    out_dir = Path(out_dir)
    f = max(1, math.ceil(max(spec.width, spec.height) / preview_cells))
    previews = []
    with open(out_dir / f"{stem}.pgm", "wb") as pgm:
        pgm.write(f"P5\n{spec.width} {spec.height}\n255\n".encode())
        pending = np.zeros((0, spec.width), np.uint8)  # rows not yet pooled (strips need not be multiples of f)
        for _row0, hits, passes in strips:
            img = _counts_to_pgm(hits, passes, occ_thresh)
            pgm.write(np.ascontiguousarray(img).tobytes())
            pending = np.concatenate([pending, img])
            cut = (len(pending) // f) * f
            if cut:
                previews.append(_pool_rank(pending[:cut], f))
                pending = pending[cut:]
        if len(pending):
            previews.append(_pool_rank(pending, f))
    _yaml(out_dir, stem, spec)
    from PIL import Image  # matplotlib's dependency; only needed here

    Image.fromarray(np.concatenate(previews) if previews else np.zeros((1, 1), np.uint8)).save(out_dir / f"{stem}.png")


def write_map(grid: OccupancyGrid, out_dir: Path, stem: str = "map") -> None:
    """Writes ``stem.pgm`` + ``stem.yaml`` (ROS map_server) and ``stem.png`` for an occupancy grid in memory."""
    img = np.full(grid.spec.shape, PGM_UNKNOWN, np.uint8)
    img[grid.log_odds > 0] = PGM_OCCUPIED
    img[grid.log_odds < 0] = PGM_FREE
    img = np.ascontiguousarray(img[::-1])  # image row 0 is the top (highest y)
    h, w = img.shape
    (Path(out_dir) / f"{stem}.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + img.tobytes())
    _yaml(Path(out_dir), stem, grid.spec)
    from PIL import Image

    Image.fromarray(img).save(Path(out_dir) / f"{stem}.png")
