"""Floor plans a user has as an occupancy image: a PNG/PGM (dark = wall, light = free), placed by a ROS
``map_server`` YAML beside it when there is one.

The YAML (``<image stem>.yaml`` next to the image, or any YAML whose ``image:`` names it) gives ``resolution``,
``origin`` ``[x, y, yaw]`` (the lower-left pixel's corner; a yaw is ignored with a warning, as map_server's own
users mostly do), ``negate``,
``occupied_thresh`` and ``free_thresh`` with map_server's meaning: a pixel's occupancy is ``p = (255 − v) / 255``
(``v / 255`` when negated; ``v / 100`` in ``mode: raw``, values above 100 unknown); free below ``free_thresh``,
occupied above ``occupied_thresh``, unknown between.
Without a YAML the pixel size is the caller's and map_server's default thresholds (0.196 / 0.65) apply.  For
simulation only free pixels are free: unknown pixels count as walls.  Colour images are read as their luminance;
transparent pixels count as unknown.

A floor plan drawn on a light background (a CAD export, a scanned plan) is light outside the building too.  That
space is not the building: :func:`outside_walls` finds it (the light space joined to the image's edge once the
walls' gaps narrower than a door are closed) so a simulated robot starts inside and explores the rooms, not the
street around them.  A map from a SLAM system has unknown space around it and nothing outside.

Example:
    >>> free, grid = read_occupancy_image("lab.png", resolution_m=0.05)  # doctest: +SKIP
    >>> free.shape == grid.shape                                          # doctest: +SKIP
    True
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.types import GridSpec

__all__ = ["MapYaml", "find_map_yaml", "outside_walls", "read_map_yaml", "read_occupancy_image"]

BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class MapYaml:
    """What a ROS ``map_server`` YAML says about its image (metres; the thresholds are occupancy probabilities)."""

    resolution_m: float
    origin_x_m: float = 0.0
    origin_y_m: float = 0.0
    negate: bool = False
    occupied_thresh: float = 0.65
    free_thresh: float = 0.196
    mode: str = "trinary"
    """``trinary`` or ``scale`` (the thresholds above), or ``raw``: a pixel's value is its occupancy in percent (0-100;
    above 100 unknown)."""


def read_map_yaml(path: str | os.PathLike[str]) -> MapYaml:
    """Reads a map_server YAML; raises ValueError naming the file when it lacks a resolution or is malformed."""
    from ruamel.yaml import YAML, YAMLError

    try:
        doc = YAML(typ="safe").load(Path(path).read_text())
    except (OSError, YAMLError, UnicodeDecodeError) as e:
        raise ValueError(f"{path}: not a readable map YAML ({type(e).__name__})") from None
    if not isinstance(doc, dict) or "resolution" not in doc:
        raise ValueError(f"{path}: a map YAML needs a 'resolution'")
    try:
        origin = [float(v) for v in doc.get("origin", [0.0, 0.0, 0.0])]
        out = MapYaml(float(doc["resolution"]), origin[0], origin[1], bool(int(doc.get("negate", 0))),
                      float(doc.get("occupied_thresh", 0.65)), float(doc.get("free_thresh", 0.196)),
                      str(doc.get("mode", "trinary")))
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"{path}: malformed resolution, origin, negate or thresholds") from None
    if out.mode not in ("trinary", "scale", "raw"):
        raise ValueError(f"{path}: unknown mode {out.mode!r} (trinary, scale or raw)")
    if len(origin) > 2 and abs(origin[2]) > 1e-9:
        warnings.warn(f"{path}: the origin's yaw ({origin[2]:g} rad) is ignored: the map is placed unrotated, in its "
                      "image's axes (as most ROS tools read it)", stacklevel=2)
    if not out.resolution_m > 0:
        raise ValueError(f"{path}: resolution must be positive, got {out.resolution_m}")
    return out


def find_map_yaml(image: Path) -> Path | None:
    """The YAML describing ``image``: ``<stem>.yaml``/``.yml`` beside it, else a YAML beside it whose ``image:``
    line names it; None when there is none."""
    for suffix in (".yaml", ".yml"):
        if (candidate := image.with_suffix(suffix)).is_file():
            return candidate
    for candidate in sorted(image.parent.glob("*.y*ml")):
        try:
            lines = candidate.read_text().splitlines()
        except (OSError, UnicodeDecodeError):
            continue
        if any(line.split(":", 1)[0].strip() == "image" and line.split(":", 1)[1].strip().strip("'\"") == image.name
               for line in lines if ":" in line):
            return candidate
    return None


def read_occupancy_image(path: str | os.PathLike[str], resolution_m: float = 0.05) -> tuple[BoolArray, GridSpec]:
    """The free cells (H, W) of an occupancy image (row 0 = lowest y, the image's bottom row) and their grid:
    resolution and origin from the map_server YAML beside it, else ``resolution_m`` and the origin at 0.

    Raises:
        ValueError: an unreadable image or YAML, or an image without a free pixel.
    """
    from PIL import Image, UnidentifiedImageError

    image_path = Path(path)
    yaml_path = find_map_yaml(image_path) if image_path.is_file() else None
    meta = read_map_yaml(yaml_path) if yaml_path is not None else MapYaml(resolution_m)
    try:
        with Image.open(image_path) as img:
            alpha = np.asarray(img.getchannel("A")) if "A" in img.getbands() else None
            gray = np.asarray(img.convert("L"), np.float64)
    except (OSError, UnidentifiedImageError, ValueError) as e:
        raise ValueError(f"{image_path}: not a readable occupancy image ({e})") from None
    if meta.mode == "raw":  # the value is the occupancy in percent; above 100 (255: -1 as a byte) unknown
        occupancy = np.where(gray <= 100, gray / 100.0, 0.5 * (meta.free_thresh + meta.occupied_thresh))
    else:
        occupancy = gray / 255.0 if meta.negate else (255.0 - gray) / 255.0
    free = occupancy < meta.free_thresh
    if alpha is not None:
        free &= alpha > 0
    if not free.any():
        raise ValueError(f"{image_path}: no free pixel (light = free, dark = wall; thresholds from "
                         f"{yaml_path or 'the map_server defaults'})")
    h, w = free.shape
    return free[::-1].copy(), GridSpec(meta.resolution_m, meta.origin_x_m, meta.origin_y_m, w, h)


def outside_walls(free: BoolArray, resolution_m: float, door_m: float = 2.0) -> BoolArray:
    """The free cells (H, W) of an image that lie outside the building it draws: the free space joined to the
    image's edge without passing a gap in the walls narrower than ``door_m`` (a door, a window, a gate).

    The gaps are told by the wall clearance: the places farther than ``door_m`` / 2 from every wall that the image's
    edge reaches are outside, and so is every free cell within ``door_m`` / 2 of them by a path in free space (the
    strip along the outer walls; a door's opening as far as that reaches, which seals it).  All False when the free
    space does not reach the edge (a map from SLAM, a plan on a dark background) or when every free cell would be
    outside (a plan cropped through its rooms: nothing can be told apart).  Gaps of ``door_m`` and wider (a garage
    door, a wall that is not drawn) join the inside to the outside.
    """
    from scipy import ndimage

    r_cells = 0.5 * door_m / resolution_m
    pad = int(np.ceil(r_cells)) + 2  # an open ring around the image: the outside can always go round the building
    open_ = np.pad(free, pad, constant_values=True)
    far = ndimage.distance_transform_edt(open_) > r_cells  # farther than door_m / 2 from every wall
    labels, _ = ndimage.label(far)  # 4-connected: a path never slips between two diagonal wall pixels
    if labels[0, 0] == 0:
        return np.zeros_like(free)
    cross = ndimage.generate_binary_structure(2, 1)
    outside = ndimage.binary_dilation(labels == labels[0, 0], cross, iterations=int(np.ceil(r_cells)), mask=open_)
    outside = outside[pad:-pad, pad:-pad] & free
    if not (free & ~outside).any():
        return np.zeros_like(free)
    return outside
