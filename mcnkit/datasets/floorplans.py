"""A procedural apartment generator (the second map domain) and the paper's HOME'S masking.

The paper's second domain, HOME'S (Japanese apartment plans), is licence-restricted; this module stands in for
it with apartments of our own, which also serve as the embedded default dataset (no download needed).  They look
unlike HouseExpo on purpose: compact rectangular footprints (often L-shaped, sometimes with a chamfered
corner), a central corridor, rooms on both sides separated by real interior walls, and doors.

Generation (:func:`generate_apartment`, deterministic per seed): a footprint of 7–15 × 6–11 m is cut by a
horizontal corridor (1.1–1.6 m wide, at 35–65 % of the depth); often one end becomes a full-depth living
room that the corridor opens into.  Each band on either side of the corridor is split along x into rooms
2.4–5 m wide; deep rooms are split again into a small front room (bath, storage) and a back room.  Every room
gets a door (0.8–1.0 m) onto the corridor or its front room, neighbours sometimes share a second door, and a
corner room may be dropped (L shape).  Rooms are shrunk by half the wall thickness (0.12 m walls), so
walls, the exterior and the chamfer are occupied and room interiors and door openings are free.

HOME'S masking (:func:`homes_mask`, the paper's "10–50 % of the map randomly replaced by unknown"): draw a
target fraction ``f ~ U(0.1, 0.5)``, then paint random axis-aligned rectangles (sides 10–35 % of the map side,
shrunk near the end so the total overshoots ``f`` by at most a few cells) until at least ``f`` of the cells are
masked; masked cells become unknown.

Example:
    >>> plan = generate_apartment(3)
    >>> free, grid = rasterize_apartment(plan, resolution_m=0.1)
    >>> bool(free.any()) and len(plan.rooms_m) >= 3
    True
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mcnkit.types import UNKNOWN, GridSpec

__all__ = ["ApartmentConfig", "ApartmentPlan", "apply_mask", "generate_apartment", "homes_mask", "rasterize_apartment"]

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class ApartmentConfig:
    """Size ranges of the procedural apartments (metres) and shape probabilities."""

    width_m: tuple[float, float] = (7.0, 15.0)
    depth_m: tuple[float, float] = (6.0, 11.0)
    corridor_m: tuple[float, float] = (1.1, 1.6)
    room_m: tuple[float, float] = (2.4, 5.0)
    wall_m: float = 0.12
    door_m: tuple[float, float] = (0.8, 1.0)
    living_room_prob: float = 0.6
    split_deep_room_prob: float = 0.5
    extra_door_prob: float = 0.3
    notch_prob: float = 0.4
    chamfer_prob: float = 0.35


@dataclass(frozen=True)
class ApartmentPlan:
    """A procedural apartment: free boxes ``[x1, y1, x2, y2]`` (metres) and occupied half-planes.

    ``rooms_m`` (R, 4): room interiors; ``doors_m`` (D, 4): door openings through walls; ``chamfers`` (K, 3):
    rows ``[a, b, c]`` making every point with ``a·x + b·y > c`` occupied.  ``footprint_m`` = outer box.
    """

    seed: int
    footprint_m: F64
    rooms_m: F64
    doors_m: F64
    chamfers: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    room_labels: tuple[str, ...] = ()

    @property
    def id(self) -> str:
        """A stable name, ``procedural:<seed>``."""
        return f"procedural:{self.seed}"

    @property
    def bbox_m(self) -> tuple[float, float, float, float]:
        """``(min_x, min_y, max_x, max_y)`` of the footprint."""
        x0, y0, x1, y1 = (float(v) for v in self.footprint_m)
        return x0, y0, x1, y1

    @property
    def room_centres_m(self) -> F64:
        """Centres (R, 2) of the rooms, in generation order."""
        r = self.rooms_m
        return np.stack([(r[:, 0] + r[:, 2]) / 2, (r[:, 1] + r[:, 3]) / 2], axis=1)


def _split(length: float, lo: float, hi: float, rng: np.random.Generator) -> list[float]:
    """Cut points splitting [0, length] into pieces of lo..hi metres (last piece merged when too short)."""
    cuts = [0.0]
    while length - cuts[-1] > hi:
        cuts.append(cuts[-1] + float(rng.uniform(lo, hi)))
    if len(cuts) > 1 and length - cuts[-1] < lo:
        cuts.pop()
    cuts.append(length)
    return cuts


def generate_apartment(seed: int, config: ApartmentConfig | None = None) -> ApartmentPlan:
    """Generates one apartment, deterministically from ``seed`` (see the module docstring for the recipe)."""
    cfg = config or ApartmentConfig()
    rng = np.random.default_rng([0xA9A7, seed])
    width = float(rng.uniform(*cfg.width_m))
    depth = float(rng.uniform(*cfg.depth_m))
    cw = float(rng.uniform(*cfg.corridor_m))
    cy0 = float(rng.uniform(0.35, 0.65)) * depth - cw / 2
    cy1 = cy0 + cw
    rooms: list[list[float]] = []  # unshrunk boxes
    labels: list[str] = []
    doors: list[list[float]] = []  # (x_or_y along the wall, wall coordinate, horizontal?) encoded as boxes later
    half = cfg.wall_m / 2

    def door_h(x_lo: float, x_hi: float, y_wall: float) -> None:  # door through a horizontal wall
        dw = min(float(rng.uniform(*cfg.door_m)), x_hi - x_lo - 2 * cfg.wall_m)
        x = float(rng.uniform(x_lo + cfg.wall_m, x_hi - cfg.wall_m - dw))
        doors.append([x, y_wall - 2 * half, x + dw, y_wall + 2 * half])

    def door_v(y_lo: float, y_hi: float, x_wall: float) -> None:  # door through a vertical wall
        dw = min(float(rng.uniform(*cfg.door_m)), y_hi - y_lo - 2 * cfg.wall_m)
        y = float(rng.uniform(y_lo + cfg.wall_m, y_hi - cfg.wall_m - dw))
        doors.append([x_wall - 2 * half, y, x_wall + 2 * half, y + dw])

    x_end = width
    if rng.random() < cfg.living_room_prob:
        lw = float(rng.uniform(3.5, max(3.6, min(6.0, width * 0.45))))
        x_end = width - lw
        rooms.append([x_end, 0.0, width, depth])
        labels.append("living")
    rooms.append([0.0, cy0, x_end, cy1])
    labels.append("corridor")
    if x_end < width:  # the corridor opens into the living room
        doors.append([x_end - 2 * half, cy0 + half, x_end + 2 * half, cy1 - half])
    drop_corner = rng.random() < cfg.notch_prob
    for lo_y, hi_y, side in ((0.0, cy0, "bottom"), (cy1, depth, "top")):
        cuts = _split(x_end, cfg.room_m[0], cfg.room_m[1], rng)
        band: list[list[float]] = []
        for k in range(len(cuts) - 1):
            x0, x1 = cuts[k], cuts[k + 1]
            if side == "top" and drop_corner and k == 0 and len(cuts) > 3:
                continue  # an L-shaped footprint: this corner is outside
            wall_y = hi_y if side == "bottom" else lo_y
            if hi_y - lo_y > 4.0 and rng.random() < cfg.split_deep_room_prob:
                split = float(rng.uniform(1.6, 2.2))
                front = [x0, wall_y - split, x1, wall_y] if side == "bottom" else [x0, wall_y, x1, wall_y + split]
                back = [x0, lo_y, x1, wall_y - split] if side == "bottom" else [x0, wall_y + split, x1, hi_y]
                rooms += [front, back]
                labels += ["bath", "bedroom"]
                door_h(x0, x1, wall_y)
                door_h(x0, x1, front[1] if side == "bottom" else front[3])
            else:
                rooms.append([x0, lo_y, x1, hi_y])
                labels.append("bedroom" if x1 - x0 > 3.0 else "kitchen")
                door_h(x0, x1, wall_y)
            if band and rng.random() < cfg.extra_door_prob:
                door_v(lo_y, hi_y, x0)
            band.append([x0, lo_y, x1, hi_y])
    boxes = np.asarray(rooms, dtype=np.float64)
    shrunk = boxes + np.array([half, half, -half, -half])
    chamfers = np.zeros((0, 3))
    if rng.random() < cfg.chamfer_prob:  # cut the bottom-right corner at 45°: x - y > width - c is occupied
        c = float(rng.uniform(1.2, 2.5))
        chamfers = np.array([[1.0, -1.0, width - c]])
    return ApartmentPlan(
        seed,
        np.array([0.0, 0.0, width, depth]),
        shrunk,
        np.asarray(doors, dtype=np.float64).reshape(-1, 4),
        chamfers,
        tuple(labels),
    )


def rasterize_apartment(
    plan: ApartmentPlan, resolution_m: float = 1.0 / 16.0, border_cells: int = 35
) -> tuple[BoolArray, GridSpec]:
    """Rasterizes an apartment: ``free`` (H, W) bool (cell centre inside a room or door box) and its grid."""
    x0, y0, x1, y1 = plan.bbox_m
    width = int(np.ceil((x1 - x0) / resolution_m - 1e-9)) + 2 * border_cells
    height = int(np.ceil((y1 - y0) / resolution_m - 1e-9)) + 2 * border_cells
    grid = GridSpec(resolution_m, x0 - border_cells * resolution_m, y0 - border_cells * resolution_m, width, height)
    xc = grid.origin_x_m + (np.arange(width) + 0.5) * resolution_m  # (W,)
    yc = grid.origin_y_m + (np.arange(height) + 0.5) * resolution_m  # (H,)
    boxes = np.concatenate([plan.rooms_m, plan.doors_m])  # (K, 4)
    in_x = (boxes[:, 0:1] <= xc[None, :]) & (xc[None, :] < boxes[:, 2:3])  # (K, W)
    in_y = (boxes[:, 1:2] <= yc[None, :]) & (yc[None, :] < boxes[:, 3:4])  # (K, H)
    free = np.einsum("kh,kw->hw", in_y.astype(np.int32), in_x.astype(np.int32)) > 0
    for a, b, c in plan.chamfers:
        free &= ~(a * xc[None, :] + b * yc[:, None] > c)
    return free, grid


def homes_mask(
    shape: tuple[int, int],
    rng: np.random.Generator,
    fraction: tuple[float, float] = (0.1, 0.5),
    side: tuple[float, float] = (0.1, 0.35),
) -> BoolArray:
    """The paper's HOME'S masking: True on ``f ~ U(fraction)`` of the cells, painted as random rectangles.

    Rectangles have sides drawn from ``side`` × the map size and are shrunk when the remaining budget is
    smaller, so the masked share ends in ``[f, f + ~2 %]``.
    """
    h, w = shape
    target = float(rng.uniform(*fraction)) * h * w
    mask = np.zeros(shape, dtype=bool)
    for _ in range(10_000):
        done = int(mask.sum())
        if done >= target:
            break
        rh = max(1, int(round(rng.uniform(*side) * h)))
        rw = max(1, int(round(rng.uniform(*side) * w)))
        budget = target - done
        while rh * rw > 2 * budget + 4 and max(rh, rw) > 1:  # shrink near the end
            rh, rw = max(1, rh // 2 if rh >= rw else rh), max(1, rw // 2 if rw > rh else rw)
        r0 = int(rng.integers(0, h - rh + 1))
        c0 = int(rng.integers(0, w - rw + 1))
        mask[r0 : r0 + rh, c0 : c0 + rw] = True
    return mask


def apply_mask(target: F32, mask: BoolArray) -> F32:
    """``target`` with the masked cells replaced by unknown (0.5)."""
    out = np.array(target, dtype=np.float32, copy=True)
    out[mask] = UNKNOWN
    return out
