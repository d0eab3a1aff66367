"""Core value types shared by every module: poses, scanner specs, scans, frames, grids and maps.

Everything here is a small frozen dataclass of numbers or numpy arrays, with units in the field
names (``x_m``, ``yaw_rad``, ``stamp_ns``).  Functions that compute on them live in
:mod:`mcnkit.geometry` and :mod:`mcnkit.grid`; these classes only hold data and check its shape.

Example:
    >>> spec = LidarSpec(angle_min_rad=-1.57, angle_increment_rad=0.0175, n_beams=180,
    ...                  range_min_m=0.0, range_max_m=30.0)
    >>> scan = Scan(ranges_m=np.full(180, 2.0, np.float32), spec=spec)
    >>> int(scan.valid.sum())
    180
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FREE",
    "OCCUPIED",
    "UNKNOWN",
    "Frame",
    "GridSpec",
    "LidarSpec",
    "OccupancyGrid",
    "Pose2D",
    "Scan",
    "TernaryMap",
    "Trajectory",
]

# The paper's ternary encoding of a map cell (the paper's map encoding).
FREE = 0.0
UNKNOWN = 0.5
OCCUPIED = 1.0

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Pose2D:
    """A planar pose: position in metres, heading in radians (counter-clockwise from +x)."""

    x_m: float = 0.0
    y_m: float = 0.0
    yaw_rad: float = 0.0

    def as_array(self) -> F64:
        """The pose as a float64 array ``[x_m, y_m, yaw_rad]``."""
        return np.array([self.x_m, self.y_m, self.yaw_rad], dtype=np.float64)

    @classmethod
    def from_array(cls, xyt: NDArray[np.floating]) -> Pose2D:
        """Builds a pose from ``[x_m, y_m, yaw_rad]``."""
        return cls(float(xyt[0]), float(xyt[1]), float(xyt[2]))


@dataclass(frozen=True)
class Trajectory:
    """Timestamped planar poses: ``stamps_ns`` (N,) int64 and ``poses`` (N, 3) float64 ``[x_m, y_m, yaw_rad]``."""

    stamps_ns: NDArray[np.int64]
    poses: F64

    def __post_init__(self) -> None:
        if self.poses.ndim != 2 or self.poses.shape[1] != 3 or len(self.stamps_ns) != len(self.poses):
            raise ValueError(
                f"Trajectory needs stamps (N,) and poses (N, 3), got {self.stamps_ns.shape} and {self.poses.shape}"
            )

    def __len__(self) -> int:
        return len(self.stamps_ns)


@dataclass(frozen=True)
class LidarSpec:
    """A planar range scanner: beam geometry, valid range interval, and its mount on the robot base.

    Beam ``i`` points at ``angle_min_rad + i * angle_increment_rad`` in the laser frame.  A range that is
    NaN, infinite or outside ``[range_min_m, range_max_m]`` is "no return".
    """

    angle_min_rad: float
    angle_increment_rad: float
    n_beams: int
    range_min_m: float
    range_max_m: float
    base_to_laser: Pose2D = field(default_factory=Pose2D)
    time_increment_s: float = 0.0
    """The time between two beams' measurements (``LaserScan.time_increment``): a spinning scanner on a moving
    robot measures each beam from another pose (see :mod:`mcnkit.slam.deskew`).  Negative: the beams were
    measured last to first (a scanner read upside down, its beams reversed); 0: not said (every beam at once)."""

    def __post_init__(self) -> None:
        if self.n_beams <= 0:
            raise ValueError(f"a scanner needs at least one beam, got n_beams={self.n_beams}")
        if not self.range_max_m > self.range_min_m >= 0.0:
            raise ValueError(f"range interval [{self.range_min_m}, {self.range_max_m}] is empty or negative")

    @property
    def angles_rad(self) -> F64:
        """Beam angles in the laser frame, shape (n_beams,)."""
        return self.angle_min_rad + self.angle_increment_rad * np.arange(self.n_beams, dtype=np.float64)

    @property
    def angle_max_rad(self) -> float:
        """Angle of the last beam."""
        return self.angle_min_rad + self.angle_increment_rad * (self.n_beams - 1)

    @property
    def beam_times_s(self) -> F64:
        """When each beam was measured, in seconds after the first measurement (the scan's stamp), shape
        (n_beams,); zeros where the scanner does not say."""
        t = self.time_increment_s * np.arange(self.n_beams, dtype=np.float64)
        return t - t.min()

    @property
    def fov_rad(self) -> float:
        """Field of view spanned by the beams (first to last beam)."""
        return abs(self.angle_increment_rad) * (self.n_beams - 1)


@dataclass(frozen=True)
class Scan:
    """One sweep of a planar scanner: raw float32 ranges exactly as logged, plus the scanner spec."""

    ranges_m: F32
    spec: LidarSpec

    def __post_init__(self) -> None:
        if self.ranges_m.shape != (self.spec.n_beams,):
            raise ValueError(f"scan has {self.ranges_m.shape} ranges but the spec says {self.spec.n_beams} beams")

    @property
    def valid(self) -> NDArray[np.bool_]:
        """True for beams with a return: finite and within ``[range_min_m, range_max_m]``."""
        r = self.ranges_m
        with np.errstate(invalid="ignore"):
            return np.isfinite(r) & (r >= self.spec.range_min_m) & (r <= self.spec.range_max_m)


@dataclass(frozen=True)
class Frame:
    """What SLAM consumes per scan: the scan, its stamp (ns), and the odometry pose of the base at that stamp."""

    stamp_ns: int
    scan: Scan
    odom: Pose2D
    odom_known: bool = True
    """False when the log holds no odometry for the motion since the previous frame (a gap in the odometry
    stream, or a jump no robot makes): ``odom`` then repeats the previous pose, and the motion is *unknown*, not
    zero (SLAM searches for it wide; see ``SlamConfig.unknown_motion_window_m``)."""


@dataclass(frozen=True)
class GridSpec:
    """A regular grid in the map frame.

    Cell ``(row, col)`` covers ``x ∈ [origin_x_m + col·res, origin_x_m + (col+1)·res)`` and likewise ``y`` with
    ``row``: row 0 is the lowest ``y`` (the ROS ``map_server`` convention, image rows flipped when saved).
    """

    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    width: int
    height: int

    def __post_init__(self) -> None:
        if self.resolution_m <= 0 or self.width <= 0 or self.height <= 0:
            raise ValueError(f"invalid grid: resolution {self.resolution_m} m, {self.width}x{self.height} cells")

    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)``, the numpy shape of an array on this grid."""
        return (self.height, self.width)

    def world_to_cell(self, xy_m: NDArray[np.floating]) -> NDArray[np.int64]:
        """Maps points (..., 2) in metres to integer cells (..., 2) as ``[row, col]`` (may lie outside)."""
        col = np.floor((xy_m[..., 0] - self.origin_x_m) / self.resolution_m)
        row = np.floor((xy_m[..., 1] - self.origin_y_m) / self.resolution_m)
        return np.stack([row, col], axis=-1).astype(np.int64)

    def world_to_cells_xy(self, xy_m: NDArray[np.floating]) -> F64:
        """Points (..., 2) ``[x_m, y_m]`` in continuous cell units ``[x, y]`` from the grid's corner (not rounded,
        not swapped to ``[row, col]``): the ray origins of the visibility kernels."""
        xy = np.asarray(xy_m, np.float64)
        return np.stack([(xy[..., 0] - self.origin_x_m) / self.resolution_m,
                         (xy[..., 1] - self.origin_y_m) / self.resolution_m], axis=-1)

    def cell_to_world(self, rc: NDArray[np.integer]) -> F64:
        """Centre (..., 2) ``[x_m, y_m]`` of cells given as (..., 2) ``[row, col]``."""
        x = self.origin_x_m + (rc[..., 1] + 0.5) * self.resolution_m
        y = self.origin_y_m + (rc[..., 0] + 0.5) * self.resolution_m
        return np.stack([x, y], axis=-1).astype(np.float64)

    def contains(self, rc: NDArray[np.integer]) -> NDArray[np.bool_]:
        """True for cells ``[row, col]`` inside the grid."""
        return (rc[..., 0] >= 0) & (rc[..., 0] < self.height) & (rc[..., 1] >= 0) & (rc[..., 1] < self.width)


@dataclass(frozen=True)
class OccupancyGrid:
    """An occupancy grid in log-odds: 0 = unknown (p = 0.5), positive = occupied, negative = free."""

    spec: GridSpec
    log_odds: F32

    def __post_init__(self) -> None:
        if self.log_odds.shape != self.spec.shape:
            raise ValueError(f"log-odds array {self.log_odds.shape} does not match grid {self.spec.shape}")

    @property
    def probabilities(self) -> F32:
        """Occupancy probability per cell, exactly 0.5 where the log-odds are 0."""
        return (1.0 / (1.0 + np.exp(-self.log_odds.astype(np.float64)))).astype(np.float32)


@dataclass(frozen=True)
class TernaryMap:
    """The paper's map image: each cell is free 0.0, unknown 0.5 or occupied 1.0 (float32, shape (H, W)).

    ``spec`` places the map in the world when known (maps resized for the network have none).
    """

    image: F32
    spec: GridSpec | None = None

    def __post_init__(self) -> None:
        if self.image.ndim != 2:
            raise ValueError(f"a ternary map is 2-D, got shape {self.image.shape}")
        if self.spec is not None and self.image.shape != self.spec.shape:
            raise ValueError(f"map image {self.image.shape} does not match grid {self.spec.shape}")

    @property
    def unknown_mask(self) -> F32:
        """The paper's mask channel: 1.0 where the cell is unknown, else 0.0."""
        return (self.image == UNKNOWN).astype(np.float32)

    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)`` of the image."""
        return (int(self.image.shape[0]), int(self.image.shape[1]))
