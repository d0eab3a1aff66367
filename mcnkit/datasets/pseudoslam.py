"""HouseExpo's Pseudo-SLAM partial maps, reproduced: the map after the first SLAM iteration.

HouseExpo's own simulator (pseudoSlam, in the upstream HouseExpo repository) works on a raster of the plan at
``px_per_m`` pixels per metre.  For each beam angle ``-fov/2, -fov/2 + step, ... < fov/2`` it walks outward
pixel by pixel (radii ``0 .. range_px``, coordinates rounded to the nearest pixel, rays leaving the raster held
at their last pixel inside it) and copies the ground truth into the observed map up to and including the first
obstacle pixel; every other pixel stays unknown.  The start pose is drawn uniformly among pixels of the window
``[0.1, 0.8)`` of the raster's height and width where a disc of the robot radius holds no obstacle, with a
uniform random heading.  Default config = HouseExpo's default (range 2 m, fov 180°, 1° steps, 16 px/m, robot
radius 0.2 m), which reproduces the paper's partial-map row.

:func:`exploration` goes further than the paper: the union of several scans, each taken from a safe pixel the
earlier scans saw free, i.e. the map of a robot part-way through exploring the house (used to train the networks
MCN-SLAM runs at every filter update, whose m_t grows scan by scan).

Example:
    >>> free = np.zeros((20, 20), bool); free[2:18, 2:18] = True
    >>> obs = pseudo_slam_scan(free, (10.0, 10.0, 0.0), PseudoSlamConfig(range_m=0.5, px_per_m=16))
    >>> bool(obs[10, 18] == OCCUPIED), bool(obs[10, 2] == UNKNOWN)
    (True, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = [
    "PseudoSlamConfig",
    "PseudoSlamObservation",
    "exploration",
    "first_iteration",
    "free_to_ternary",
    "pseudo_slam_scan",
    "random_start_pose",
]

F32 = NDArray[np.float32]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class PseudoSlamConfig:
    """HouseExpo Pseudo-SLAM settings (defaults: its default config).

    Attributes:
        range_m: laser range; ``range_px = int(range_m * px_per_m)``.
        fov_deg: field of view; beams from ``-fov/2`` (inclusive) to ``+fov/2`` (exclusive).
        step_deg: angular step between beams.
        px_per_m: raster resolution (pixels per metre).
        robot_radius_m: start poses keep obstacles farther than this (``int(robot_radius_m * px_per_m)`` px).
        border_px: occupied border around the plan's bounding box (HouseExpo: 25 render + 10 padding).
        start_window: fraction of height and width the start pixel is drawn from, ``[lo, hi)``.
    """

    range_m: float = 2.0
    fov_deg: float = 180.0
    step_deg: float = 1.0
    px_per_m: float = 16.0
    robot_radius_m: float = 0.2
    border_px: int = 35
    start_window: tuple[float, float] = (0.1, 0.8)

    def __post_init__(self) -> None:
        if self.range_m <= 0 or self.fov_deg <= 0 or self.step_deg <= 0 or self.px_per_m <= 0:
            raise ValueError(f"range, fov, step and resolution must be positive: {self}")
        if not 0.0 <= self.start_window[0] < self.start_window[1] <= 1.0:
            raise ValueError(f"start_window must satisfy 0 <= lo < hi <= 1, got {self.start_window}")

    @property
    def range_px(self) -> int:
        """Laser range in pixels."""
        return int(self.range_m * self.px_per_m)

    @property
    def robot_radius_px(self) -> int:
        """Robot radius in pixels."""
        return int(self.robot_radius_m * self.px_per_m)

    @property
    def beam_angles_rad(self) -> NDArray[np.float64]:
        """Beam angles relative to the heading, as HouseExpo builds them (``np.arange``)."""
        half = np.deg2rad(self.fov_deg) * 0.5
        return np.arange(-half, half, np.deg2rad(self.step_deg))


@dataclass(frozen=True)
class PseudoSlamObservation:
    """Ground truth and the first-iteration partial map, both ternary (H, W) float32, plus the start pose.

    ``pose_px`` is ``(row, col, yaw_rad)`` on the raster (row grows with y; yaw counter-clockwise from +x).
    """

    ground_truth: F32
    observed: F32
    pose_px: tuple[float, float, float]
    last_pose_px: tuple[float, float, float] | None = None
    """The last scan's pose, where the robot is now (None: ``pose_px``, the only scan)."""


def free_to_ternary(free: BoolArray) -> F32:
    """Free (True) → 0.0, everything else → 1.0 (walls and exterior occupied)."""
    return np.where(free, FREE, OCCUPIED).astype(np.float32)


def pseudo_slam_scan(free: BoolArray, pose_px: tuple[float, float, float], config: PseudoSlamConfig) -> F32:
    """One Pseudo-SLAM scan from ``pose_px`` = (row, col, yaw): the observed ternary map (H, W).

    Vectorised over beams and radii: coordinates (B, R+1) are rounded, clamped to the last in-raster pixel of
    their ray, and every pixel up to and including the first obstacle of each ray copies the ground truth.
    """
    h, w = free.shape
    row0, col0, yaw = pose_px
    angles = (yaw + config.beam_angles_rad)[:, None]  # (B, 1)
    radii = np.arange(config.range_px + 1, dtype=np.float64)[None, :]  # (1, R+1)
    rows = np.round(row0 + np.sin(angles) * radii).astype(np.int64)  # (B, R+1)
    cols = np.round(col0 + np.cos(angles) * radii).astype(np.int64)
    inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    # Hold each ray at its last pixel inside the raster (HouseExpo's bound handling).
    last_in = np.maximum.accumulate(np.where(inside, np.arange(rows.shape[1])[None, :], 0), axis=1)
    rows = np.take_along_axis(rows, last_in, axis=1).clip(0, h - 1)
    cols = np.take_along_axis(cols, last_in, axis=1).clip(0, w - 1)
    hit = ~free[rows, cols]  # (B, R+1)
    first = np.argmax(hit, axis=1)
    first[first == 0] = rows.shape[1]  # no obstacle (or one under the robot): the whole ray, as HouseExpo
    seen = np.arange(rows.shape[1])[None, :] <= first[:, None]
    observed = np.full(free.shape, UNKNOWN, dtype=np.float32)
    r, c = rows[seen], cols[seen]
    observed[r, c] = np.where(free[r, c], FREE, OCCUPIED)
    return observed


def random_start_pose(
    free: BoolArray, config: PseudoSlamConfig, rng: np.random.Generator
) -> tuple[float, float, float]:
    """A start pose (row, col, yaw) drawn like HouseExpo's ``_randomizeRobotPose``.

    Uniform over the window pixels whose robot disc holds no obstacle (the same law as HouseExpo's rejection
    loop); if the window has none, over all such pixels; if none at all, over free pixels.

    Raises:
        ValueError: the raster has no free pixel.
    """
    h, w = free.shape
    radius = config.robot_radius_px
    clearance = ndimage.distance_transform_edt(free)  # distance to the nearest obstacle pixel centre
    safe = clearance > radius
    safe[:radius, :] = safe[h - radius :, :] = False
    safe[:, :radius] = safe[:, w - radius :] = False
    lo, hi = config.start_window
    window = np.zeros_like(safe)
    window[int(lo * h) : int(hi * h), int(lo * w) : int(hi * w)] = True
    for cand in (safe & window, safe, free):
        rc = np.flatnonzero(cand)
        if rc.size:
            k = int(rc[rng.integers(rc.size)])
            yaw = float(rng.random() * 2.0 * np.pi)
            return float(k // w), float(k % w), yaw
    raise ValueError("the map has no free pixel to start from")


def first_iteration(free: BoolArray, config: PseudoSlamConfig, rng: np.random.Generator) -> PseudoSlamObservation:
    """The paper's m_t and m_T on the raster: one scan from a random free start pose, and the ground truth."""
    return exploration(free, config, 1, rng)


def exploration(
    free: BoolArray, config: PseudoSlamConfig, n_scans: int, rng: np.random.Generator
) -> PseudoSlamObservation:
    """m_t after ``n_scans`` scans: the first from :func:`random_start_pose`, each next one from a pixel drawn
    uniformly among the safe pixels (robot disc clear of obstacles) that the scans so far observed free — where a
    robot that drives only through known free space can be — with a uniform heading.  ``pose_px`` is the first
    pose, ``last_pose_px`` the last.  ``n_scans = 1`` is the paper's :func:`first_iteration`.
    """
    if n_scans < 1:
        raise ValueError(f"n_scans must be at least 1, got {n_scans}")
    first = random_start_pose(free, config, rng)
    observed = pseudo_slam_scan(free, first, config)
    pose = first
    if n_scans > 1:
        safe = ndimage.distance_transform_edt(free) > config.robot_radius_px
        for _ in range(n_scans - 1):
            cand = np.flatnonzero(safe & (observed == FREE))
            if cand.size == 0:
                break
            k = int(cand[rng.integers(cand.size)])
            pose = (float(k // free.shape[1]), float(k % free.shape[1]), float(rng.random() * 2.0 * np.pi))
            scan = pseudo_slam_scan(free, pose, config)
            seen = scan != UNKNOWN
            observed[seen] = scan[seen]
    return PseudoSlamObservation(free_to_ternary(free), observed, first, pose)
