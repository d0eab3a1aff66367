"""A scan as the robot would have seen it standing still at the scan's stamp.

A spinning scanner measures its beams one after another: a 360° scanner that turns 7-10 times a second (an RPLIDAR,
an LD19) sweeps for 0.1-0.15 s, and a robot turning at 1 rad/s turns 6-9° in that time, so the wall the last beam
sees sits 6-9° off where the first beam's frame puts it: every turn smears the map and pulls the match (a seam where
the sweep starts and ends).  ``LaserScan.time_increment`` says when each beam was measured
(:attr:`mcnkit.types.LidarSpec.beam_times_s`); :func:`deskew_ranges` moves each return to where the robot was at the
scan's stamp (ROS stamps a scan at its first beam), the robot moving at a constant velocity through the sweep, and
puts the returns back on the scanner's beams: each on the beam nearest its new direction, the nearer return where
two land on one beam, and "no return" on a beam that had one and receives none.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, inverse
from mcnkit.types import LidarSpec

__all__ = ["deskew_ranges"]


def deskew_ranges(ranges_m: NDArray[np.floating], spec: LidarSpec, velocity: NDArray[np.float64]) -> NDArray[np.float32]:
    """``ranges_m`` of ``spec``'s beams as measured from the robot's pose at the first beam's time, the robot moving
    at ``velocity`` (3,: m/s forward and left, rad/s counter-clockwise, in the robot's frame) through the sweep.

    Readings that are no return stay as logged unless a return lands on their beam; a return that moves out of a
    scanner's field of view (less than a full turn) is dropped.  Unchanged when the scanner does not say when its
    beams were measured (``time_increment_s`` 0)."""
    times = spec.beam_times_s
    r = np.asarray(ranges_m, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(r) & (r >= spec.range_min_m) & (r <= spec.range_max_m)
    if not times.any() or not valid.any() or not np.any(velocity):
        return np.asarray(ranges_m, dtype=np.float32)
    t, rv = times[valid], r[valid]
    a = spec.angles_rad[valid]
    mount = spec.base_to_laser.as_array()
    at_beam = compose(mount, np.stack([rv * np.cos(a), rv * np.sin(a), np.zeros_like(rv)], axis=1))  # base at t
    moved = t[:, None] * np.asarray(velocity, dtype=np.float64)[None, :]  # the base at t, from the base at the stamp
    in_scanner = compose(inverse(mount), compose(moved, at_beam))
    r_new = np.hypot(in_scanner[:, 0], in_scanner[:, 1])
    steps = (np.arctan2(in_scanner[:, 1], in_scanner[:, 0]) - spec.angle_min_rad) / spec.angle_increment_rad
    n = spec.n_beams
    full_turn = spec.fov_rad + 1.5 * abs(spec.angle_increment_rad) >= 2.0 * math.pi
    period = 2.0 * math.pi / abs(spec.angle_increment_rad)
    k = np.rint(np.mod(steps, period) if full_turn else steps).astype(np.int64)
    if full_turn:
        k = np.where(k >= n, k - int(round(period)), k)
    keep = (k >= 0) & (k < n)
    nearest = np.full(n, np.inf)
    np.minimum.at(nearest, k[keep], r_new[keep])
    landed = np.isfinite(nearest)
    return np.where(landed, nearest, np.where(valid, np.nan, r)).astype(np.float32)
