"""The scanner's direction on the robot, found from the robot's motion, for a log that does not say it.

A bag recorded without ``/tf_static`` (``ros2 bag record /scan /odom /tf``, a common command) holds the scans and
the odometry but not where the scanner points on the base, and scanners are often mounted turned: a quarter turn,
backwards, upside down.  Taken to face forward, such a scanner sees the world move sideways as the robot drives
ahead, and every scan contradicts the odometry.

The scans placed with the odometry make the sharpest map when each beam is turned the way it really points: a wrong
direction smears every wall the robot drives past.  :func:`fit_mount` tries every direction (the whole turn, 3°
apart) and both senses of sweep (a scanner upside down sweeps clockwise); for the best few it tries offsets of the
scanner on the base (up to 0.6 m each way, 0.15 m apart: an offset left out smears the map as the robot turns, and
can favour a wrong direction), then refines the best to 0.25° and 2.5 cm.  Each is scored by the points'
sharpness: the quadratic Rényi entropy's kernel sum, Σᵢⱼ exp(−|pᵢ − pⱼ|² / 4σ²), computed on a grid (the points'
counts, blurred by a Gaussian, times the counts).  The same measure calibrates lidars in the literature (Sheehan,
Harrison and Newman, "Self-calibration for a 3D laser", IJRR 2012).  The motion tells the direction only where the
robot *drives*: a robot that only turns in place sees the same map at every yaw.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace

import numba
import numpy as np
from numpy.typing import NDArray

from mcnkit.types import Frame, Pose2D, Scan

__all__ = ["MountFit", "MountSample", "as_mounted", "fit_mount", "mount_from_motion", "mount_sample"]

_COARSE_STEP_RAD = math.radians(3.0)
_FINE_STEP_RAD = math.radians(0.25)
_COARSE_CELL_M, _FINE_CELL_M = 0.1, 0.05
_MAX_OFFSET_M, _COARSE_OFFSET_STEP_M, _FINE_OFFSET_STEP_M = 0.6, 0.15, 0.025
_CANDIDATES = 4
_MAX_RANGE_M = 15.0  # farther returns add smear from the odometry's own heading error, not information
_COARSE_POINTS, _FINE_POINTS = 20_000, 60_000  # at most this many returns enter a score (thinned evenly beyond)
MIN_PATH_M = 2.0  # the robot must drive this far for its motion to tell where the scanner points
MIN_TURN_RAD = math.radians(10.0)  # a scanner found this close to facing forward is taken to face forward
MIN_GAIN = 1.1  # and one found turned must make a map this much sharper than facing forward


@dataclass(frozen=True)
class MountSample:
    """The returns a fit looks at: ``odom_xyt`` (F, 3) the base's odometry poses of the frames taken (relative to
    the first), and per return (within ``_MAX_RANGE_M``) its frame ``frame_index`` (R,), ``range_m`` (R,) and beam
    angle in the scanner's frame ``angle_rad`` (R,); ``path_m`` is the odometry's path length over the frames."""

    odom_xyt: NDArray[np.float64]
    frame_index: NDArray[np.int32]
    range_m: NDArray[np.float32]
    angle_rad: NDArray[np.float32]
    path_m: float


@dataclass(frozen=True)
class MountFit:
    """The scanner's mount on the base that makes the sharpest map: ``yaw_rad`` (where its x axis points,
    counter-clockwise from the base's x), ``upside_down`` (its beams sweep clockwise, seen from above) and its
    position ``x_m``, ``y_m``; ``sharpness_gain`` is that map's sharpness over the one a scanner at the base facing
    forward makes (1: no better); ``path_m`` how far the robot drove in the scans it was found from."""

    yaw_rad: float
    upside_down: bool
    x_m: float
    y_m: float
    sharpness_gain: float
    path_m: float


def mount_sample(frames: Iterable[Frame], *, path_m: float = 8.0, step_m: float = 0.1,
                 step_rad: float = math.radians(5.0), max_frames: int = 150, max_read: int = 20_000) -> MountSample:
    """The first stretch of ``frames`` with odometry, one frame every ``step_m`` of travel or ``step_rad`` of turn,
    until the robot drove ``path_m`` or ``max_frames`` were taken (a gap in the odometry starts the stretch anew).
    ``frames`` is read only as far as that, and never past ``max_read`` frames (a robot that stands still for
    minutes: what it drove by then is what the fit gets)."""
    poses: list[tuple[float, float, float]] = []
    index: list[NDArray[np.int32]] = []
    ranges: list[NDArray[np.float32]] = []
    angles: list[NDArray[np.float32]] = []
    travelled = 0.0
    for f in itertools.islice(frames, max_read):
        if not f.odom_known:
            if travelled < path_m:
                poses, index, ranges, angles, travelled = [], [], [], [], 0.0
            continue
        p = (f.odom.x_m, f.odom.y_m, f.odom.yaw_rad)
        if poses:
            step = math.hypot(p[0] - poses[-1][0], p[1] - poses[-1][1])
            turn = abs(math.remainder(p[2] - poses[-1][2], math.tau))
            if step < step_m and turn < step_rad:
                continue
            travelled += step
        keep = np.flatnonzero(f.scan.valid & (f.scan.ranges_m <= _MAX_RANGE_M))
        index.append(np.full(len(keep), len(poses), np.int32))
        ranges.append(f.scan.ranges_m[keep].astype(np.float32))
        angles.append(f.scan.spec.angles_rad[keep].astype(np.float32))
        poses.append(p)
        if travelled >= path_m or len(poses) >= max_frames:
            break
    if not poses:
        return MountSample(np.zeros((0, 3)), np.zeros(0, np.int32), np.zeros(0, np.float32), np.zeros(0, np.float32), 0.0)
    xyt = np.array(poses, dtype=np.float64)
    xyt[:, :2] -= xyt[0, :2]  # small numbers: the points are placed in float32
    return MountSample(xyt, np.concatenate(index), np.concatenate(ranges), np.concatenate(angles), travelled)


_KERNEL_REACH = 3  # cells each way: the Gaussian (σ = 1 cell) cut at 3σ


@numba.njit(cache=True)
def _kernel_sum(xyt: NDArray[np.float64], frame: NDArray[np.int32], r: NDArray[np.float32], a: NDArray[np.float32],
                yaw: float, sweep: float, dx: float, dy: float, cell: float, stride: int) -> float:  # pragma: no cover
    """Σ over every ``stride``-th point p and every point q of exp(−|cell(p) − cell(q)|² / 2) (in cells), per pair:
    the points' counts on a grid of ``cell`` metres, blurred by a unit Gaussian, summed at the points."""
    n = (len(r) + stride - 1) // stride
    xs = np.empty(n, np.float32)
    ys = np.empty(n, np.float32)
    for k in range(n):
        i = k * stride
        px, py, pt = xyt[frame[i], 0], xyt[frame[i], 1], xyt[frame[i], 2]
        c, s = np.cos(pt), np.sin(pt)
        h = pt + yaw + sweep * a[i]
        xs[k] = px + c * dx - s * dy + r[i] * np.cos(h)
        ys[k] = py + s * dx + c * dy + r[i] * np.sin(h)
    x0, y0 = xs.min(), ys.min()
    pad = _KERNEL_REACH
    w = int((xs.max() - x0) / cell) + 1 + 2 * pad
    h_ = int((ys.max() - y0) / cell) + 1 + 2 * pad
    counts = np.zeros((w, h_), np.uint16)
    for k in range(n):
        counts[int((xs[k] - x0) / cell) + pad, int((ys[k] - y0) / cell) + pad] += 1
    weight = np.exp(-0.5 * np.arange(-pad, pad + 1) ** 2)
    total = 0.0
    for k in range(n):
        cx, cy = int((xs[k] - x0) / cell) + pad, int((ys[k] - y0) / cell) + pad
        for i in range(-pad, pad + 1):
            for j in range(-pad, pad + 1):
                total += weight[i + pad] * weight[j + pad] * counts[cx + i, cy + j]
    return total / (n * n)


def _sharpness(sample: MountSample, yaw_rad: float, upside_down: bool, fine: bool,
               offset_m: tuple[float, float] = (0.0, 0.0)) -> float:
    """The kernel sum of the sample's points with the scanner turned by ``yaw_rad`` (mirrored if ``upside_down``)
    and sitting at ``offset_m`` on the base, per pair of points (higher: sharper); ``fine``: on the finer grid,
    with more of the points."""
    cell_m, points = (_FINE_CELL_M, _FINE_POINTS) if fine else (_COARSE_CELL_M, _COARSE_POINTS)
    stride = max(1, -(-len(sample.range_m) // points))
    return float(_kernel_sum(sample.odom_xyt, sample.frame_index, sample.range_m, sample.angle_rad, yaw_rad,
                             -1.0 if upside_down else 1.0, offset_m[0], offset_m[1], cell_m, stride))


def _grid(step: float, reach: float) -> list[tuple[float, float]]:
    ticks = np.arange(-reach, reach + step / 2, step)
    return [(float(x), float(y)) for x in ticks for y in ticks]


def fit_mount(sample: MountSample) -> MountFit:
    """The direction, sense of sweep and offset that make ``sample``'s map sharpest (see the module docstring)."""
    if len(sample.odom_xyt) < 2 or not len(sample.range_m):
        return MountFit(0.0, False, 0.0, 0.0, 1.0, sample.path_m)
    coarse = np.arange(0.0, math.tau, _COARSE_STEP_RAD)
    scores = np.array([[_sharpness(sample, float(yaw), flip, False) for yaw in coarse]
                       for flip in (False, True)])
    # the best few directions (local maxima of either sweep), each with the offset that suits it best: an offset
    # left out smears the map as the robot turns, and can favour a wrong direction
    peaks = [(scores[f, i], f, i) for f in (0, 1) for i in range(len(coarse))
             if scores[f, i] >= scores[f, i - 1] and scores[f, i] >= scores[f, (i + 1) % len(coarse)]]
    candidates = []
    for _, f, i in sorted(peaks, reverse=True)[:_CANDIDATES]:
        yaw, flip = float(coarse[i]), bool(f)
        score, offset = max((_sharpness(sample, yaw, flip, False, o), o)
                            for o in _grid(_COARSE_OFFSET_STEP_M, _MAX_OFFSET_M))
        candidates.append((score, yaw, flip, offset))
    _, yaw0, flip, offset = max(candidates)
    fine = yaw0 + np.arange(-_COARSE_STEP_RAD, _COARSE_STEP_RAD + _FINE_STEP_RAD / 2, _FINE_STEP_RAD)
    _, yaw = max((_sharpness(sample, float(y), flip, True, offset), float(y)) for y in fine)
    near = [(offset[0] + dx, offset[1] + dy) for dx, dy in _grid(_FINE_OFFSET_STEP_M, _COARSE_OFFSET_STEP_M)]
    score, offset = max((_sharpness(sample, yaw, flip, True, o), o) for o in near)
    forward = _sharpness(sample, 0.0, False, True)
    return MountFit(math.remainder(yaw, math.tau), flip, round(offset[0], 6), round(offset[1], 6),
                    score / forward if forward > 0 else 1.0, sample.path_m)


def mount_from_motion(frames: Iterable[Frame]) -> tuple[Pose2D, bool, str]:
    """The mount ``frames`` (read with the scanner facing forward at the base) show, whether the scanner is upside
    down, and what was found, in words: the sharpest map's mount (:func:`fit_mount`) where it is plainly turned
    (more than ``MIN_TURN_RAD`` or upside down, and ``MIN_GAIN`` times as sharp as facing forward); else the scanner
    at the base, facing forward (also where the robot drives less than ``MIN_PATH_M``)."""
    forward = "the scanner is taken to sit at the base, facing forward"
    sample = mount_sample(frames)
    if sample.path_m < MIN_PATH_M:
        return Pose2D(), False, (forward + f" (the robot drives {sample.path_m:.1f} m in the stretch looked at: too "
                                           "little to find the scanner's direction from the motion)")
    fit = fit_mount(sample)
    best = (f"the sharpest map has the scanner at {math.degrees(fit.yaw_rad):.0f}°"
            f"{', upside down' if fit.upside_down else ''}, {fit.sharpness_gain:.2f}× as sharp")
    if not (abs(fit.yaw_rad) > MIN_TURN_RAD or fit.upside_down):
        return Pose2D(), False, forward + f" (the robot's first {fit.path_m:.0f} m agree with it: {best})"
    if fit.sharpness_gain < MIN_GAIN:
        return Pose2D(), False, forward + f" (the robot's first {fit.path_m:.0f} m do not tell: {best})"
    return Pose2D(fit.x_m, fit.y_m, fit.yaw_rad), fit.upside_down, (
        f"from the robot's first {fit.path_m:.0f} m, the scanner points {math.degrees(fit.yaw_rad):.1f}° from the "
        f"base's x axis{', upside down (its beams sweep clockwise)' if fit.upside_down else ''}, at "
        f"({fit.x_m:.2f}, {fit.y_m:.2f}) m (a map {fit.sharpness_gain:.1f}× as sharp as with it facing forward)")


def as_mounted(frames: Iterable[Frame], mount: Pose2D, upside_down: bool = False) -> Iterator[Frame]:
    """``frames`` (of a scanner at the base, facing forward) as a scanner mounted at ``mount``, upside down or not,
    logs them: the same beams in the world, the scanner's own angles (its spec naming ``mount``) and the base's
    odometry.  Written without ``/tf_static`` (``LogContent(mount_transform=False)``), they are a log whose mount the
    reader has to find."""
    spec = None
    dx_m, dy_m = mount.x_m, mount.y_m
    for f in frames:
        if spec is None:
            s = f.scan.spec
            amin = mount.yaw_rad - s.angle_max_rad if upside_down else s.angle_min_rad - mount.yaw_rad
            spec = replace(s, angle_min_rad=amin, base_to_laser=mount)
        o = f.odom  # the scanner is where the frame's base was; the base sits the mount's offset behind it
        c, s_ = math.cos(o.yaw_rad), math.sin(o.yaw_rad)
        base = Pose2D(o.x_m - c * dx_m + s_ * dy_m, o.y_m - s_ * dx_m - c * dy_m, o.yaw_rad)
        ranges = f.scan.ranges_m[::-1].copy() if upside_down else f.scan.ranges_m
        yield Frame(f.stamp_ns, Scan(ranges, spec), base, f.odom_known)
