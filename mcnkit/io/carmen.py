"""CARMEN logs (``.clf``, ``.log``, gzip'd or not) and DP-SLAM logs.

Lines understood:

* ``FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp``: a front
  laser scan, 180° wide starting at -90°: 181/361/721 beams span -90..+90°, other counts (e.g. 180) use
  steps of 180°/n (-90..+89° for 180 beams, as in the Intel lab log).
* ``ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn m e1..em
  laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fwd side turn ipc_timestamp host logger_ts``.
* ``ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp``.
* DP-SLAM's ``Odometry x y theta`` and ``Laser n r1..rn`` (181 beams -90..+90°, no timestamps: frames are
  stamped ``index × dpslam_period_s``).

Odometry per scan is the odometry pose logged on the scan line.  The Radish "corrected" variant (the
Intel lab log) is recognised by its ``ODOM`` stream re-anchored at each scan's pose: there the scan line
holds the SLAM-corrected pose (kept as ground truth) and the raw odometry is rebuilt by chaining
``inverse(corrected_k) ⊕ (last ODOM pose before scan k+1)``, starting from the first corrected pose.

"No return": these logs mark it with a sentinel at the top of the range (81.91, 81.83 or 8.191 m).  When more
than 0.05 % of all readings (and at least 20) sit within 5 mm of the largest reading, that reading is the sentinel and the
scanner's ``range_max_m`` is set 2 cm below it; otherwise ``range_max_m`` is the largest reading.
"""

from __future__ import annotations

import gzip
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mcnkit.geometry import compose, relative, wrap_angle
from mcnkit.io.base import LogReader, TopicInfo
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan, Trajectory

__all__ = ["CarmenLog", "is_carmen"]

_SCAN_KEYWORDS = ("FLASER", "ROBOTLASER1", "Laser")
_KEYWORDS = (*_SCAN_KEYWORDS, "ODOM", "Odometry", "PARAM", "NEFF", "SYNC", "RLASER", "TRUEPOS", "RAWLASER1")


def _open_text(path: Path) -> Iterator[str]:
    opener = gzip.open if path.read_bytes()[:2] == b"\x1f\x8b" else open
    try:
        with opener(path, "rt", encoding="ascii", errors="replace") as f:
            yield from f
    except (OSError, EOFError) as err:  # truncated gzip stream
        warn_skipped(path, f"the compressed stream ends early ({err}); read what came before")


def is_carmen(path: Path) -> bool:
    """True when the first non-comment line of ``path`` starts with a CARMEN or DP-SLAM keyword."""
    try:
        for line in _open_text(path):
            word = line.split(maxsplit=1)[0] if line.strip() else ""
            if not word or word.startswith("#"):
                continue
            return word in _KEYWORDS
    except (OSError, UnicodeDecodeError, IndexError):
        return False
    return False


def _stamp_ns(text: str) -> int:
    """Exact nanoseconds from a decimal seconds string (no float rounding)."""
    sign = -1 if text.startswith("-") else 1
    whole, _, frac = text.lstrip("+-").partition(".")
    return sign * (int(whole or 0) * 1_000_000_000 + int((frac + "000000000")[:9] or 0))


@dataclass
class _Parsed:
    stamps_ns: list[int] = field(default_factory=list)
    ranges: list[np.ndarray] = field(default_factory=list)
    scan_pose: list[tuple[float, float, float]] = field(default_factory=list)  # pose logged on the scan line
    odom_on_scan: list[tuple[float, float, float]] = field(default_factory=list)
    geometry: list[tuple[float, float, float]] = field(default_factory=list)  # angle_min, increment, max range
    odom_lines: list[tuple[float, float, float]] = field(default_factory=list)
    last_odom_before_scan: list[int] = field(default_factory=list)  # index into odom_lines, -1 if none
    first_odom_after_scan: dict[int, int] = field(default_factory=dict)
    dpslam_odom: tuple[float, float, float] | None = None
    skipped: int = 0
    kind: str = "carmen"


def _flaser_geometry(n: int) -> tuple[float, float]:
    step_deg = 180.0 / (n - 1) if n in (181, 361, 721) else 180.0 / n
    return math.radians(-90.0), math.radians(step_deg)


def _parse(path: Path, dpslam_period_s: float) -> _Parsed:
    out = _Parsed()
    for lineno, line in enumerate(_open_text(path), start=1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        key = tok[0]
        try:
            if key == "FLASER":
                n = int(tok[1])
                r = np.array(tok[2 : 2 + n], dtype=np.float32)
                rest = tok[2 + n :]
                if len(r) != n or len(rest) < 7:
                    raise ValueError("short line")
                amin, inc = _flaser_geometry(n)
                _add_scan(out, _stamp_ns(rest[6]), r, rest[0:3], rest[3:6], (amin, inc, math.inf))
            elif key == "ROBOTLASER1":
                start, fov, res, max_range = (float(t) for t in tok[2:6])
                n = int(tok[8])
                r = np.array(tok[9 : 9 + n], dtype=np.float32)
                m = int(tok[9 + n])
                rest = tok[10 + n + m :]
                if len(r) != n or len(rest) < 14:
                    raise ValueError("short line")
                del fov
                _add_scan(out, _stamp_ns(rest[11]), r, rest[0:3], rest[3:6], (start, res, max_range))
            elif key == "ODOM":
                out.odom_lines.append((float(tok[1]), float(tok[2]), float(tok[3])))
                if out.stamps_ns and len(out.stamps_ns) - 1 not in out.first_odom_after_scan:
                    out.first_odom_after_scan[len(out.stamps_ns) - 1] = len(out.odom_lines) - 1
            elif key == "Odometry":
                out.kind = "dpslam"
                out.dpslam_odom = (float(tok[1]), float(tok[2]), float(tok[3]))
            elif key == "Laser":
                out.kind = "dpslam"
                n = int(tok[1])
                r = np.array(tok[2 : 2 + n], dtype=np.float32)
                if len(r) != n or out.dpslam_odom is None:
                    raise ValueError("short line or no Odometry line before it")
                stamp = round(len(out.stamps_ns) * dpslam_period_s * 1e9)
                odom = out.dpslam_odom
                _add_scan(out, stamp, r, odom, odom, (math.radians(-90.0), math.radians(180.0 / (n - 1)), math.inf))
        except (ValueError, IndexError):
            out.skipped += 1
            if out.skipped <= 1:
                warn_skipped(path, f"line {lineno}: malformed {key} line skipped")
    return out


def _add_scan(
    out: _Parsed, stamp_ns: int, r: np.ndarray, pose: list[str] | tuple, odom: list[str] | tuple,
    geometry: tuple[float, float, float],
) -> None:
    out.stamps_ns.append(stamp_ns)
    out.ranges.append(r)
    out.scan_pose.append((float(pose[0]), float(pose[1]), float(pose[2])))
    out.odom_on_scan.append((float(odom[0]), float(odom[1]), float(odom[2])))
    out.geometry.append(geometry)
    out.last_odom_before_scan.append(len(out.odom_lines) - 1)


def _is_corrected_variant(p: _Parsed) -> bool:
    """Radish corrected logs re-anchor ODOM at every scan's pose: the first ODOM after a scan equals it."""
    pairs = [(k, j) for k, j in p.first_odom_after_scan.items()]
    if len(pairs) < max(3, len(p.stamps_ns) // 2):
        return False
    hits = sum(np.allclose(p.odom_lines[j], p.scan_pose[k], atol=1e-6) for k, j in pairs)
    return hits >= 0.9 * len(pairs)


def _rebuild_raw_odometry(p: _Parsed) -> np.ndarray:
    corrected = np.asarray(p.scan_pose, dtype=np.float64)
    odom = np.empty_like(corrected)
    odom[0] = corrected[0]
    for k in range(len(corrected) - 1):
        j = p.last_odom_before_scan[k + 1]
        increment = relative(corrected[k], np.asarray(p.odom_lines[j])) if j >= 0 else np.zeros(3)
        odom[k + 1] = compose(odom[k], increment)
    return odom


def _range_max(ranges: list[np.ndarray]) -> float:
    allr = np.concatenate(ranges)
    allr = allr[np.isfinite(allr)]
    top = float(allr.max())
    near_top = np.count_nonzero(allr >= top - 0.005)
    return round(top - 0.02 if near_top >= max(20, 0.0005 * len(allr)) else top, 6)


class CarmenLog(LogReader):
    """A CARMEN or DP-SLAM log held in memory (these logs are small: MIT CSAIL is 6 MB)."""

    def __init__(self, path: Path, dpslam_period_s: float = 0.2) -> None:
        self.path = path
        p = _parse(path, dpslam_period_s)
        if not p.stamps_ns:
            raise LogError(path, "no laser scans (FLASER, ROBOTLASER1 or Laser lines) in this CARMEN log")
        if p.skipped:
            warn_skipped(path, f"{p.skipped} malformed line(s) skipped")
        n_beams = {len(r) for r in p.ranges}
        if len(n_beams) > 1:
            raise LogError(path, f"scans have different beam counts {sorted(n_beams)}")
        self.format = "dpslam" if p.kind == "dpslam" else "carmen"
        self._gt: Trajectory | None = None
        stamps = np.asarray(p.stamps_ns, dtype=np.int64)
        if self.format == "carmen" and _is_corrected_variant(p):
            self.format = "carmen-corrected"
            odom = _rebuild_raw_odometry(p)
            self._gt = Trajectory(stamps.copy(), np.asarray(p.scan_pose, dtype=np.float64))
        else:
            odom = np.asarray(p.odom_on_scan, dtype=np.float64)
        order = np.argsort(stamps, kind="stable")  # IPC clock jitter: a few scans are stamped before the last
        if (order != np.arange(len(order))).any():
            n_late = int(np.count_nonzero(np.maximum.accumulate(stamps) != stamps))
            warn_skipped(path, f"{n_late} scan(s) stamped earlier than the scan before them; frames sorted by stamp")
        odom[:, 2] = wrap_angle(odom[:, 2])  # logs hold headings outside [-pi, pi)
        self._stamps = stamps[order]
        self._odom = odom[order]
        self._ranges = np.stack(p.ranges)[order]
        if self._gt is not None:
            gt_poses = self._gt.poses[order]
            gt_poses[:, 2] = wrap_angle(gt_poses[:, 2])
            self._gt = Trajectory(self._gt.stamps_ns[order], gt_poses)
        amin, inc, max_range = p.geometry[0]
        # The scan line's laser pose and robot pose give the mount offset of the laser on the base.
        laser0, robot0 = np.asarray(p.scan_pose[0]), np.asarray(p.odom_on_scan[0])
        offset = np.round(relative(robot0, laser0), 9) if self.format == "carmen" else np.zeros(3)
        if np.hypot(offset[0], offset[1]) > 2.0:  # not a mount offset: the two poses are in different frames
            offset = np.zeros(3)
        offset += 0.0  # no negative zeros
        rmax = _range_max(p.ranges) if math.isinf(max_range) else max_range
        self._spec = LidarSpec(amin, inc, int(self._ranges.shape[1]), 0.0, rmax, Pose2D.from_array(offset))
        self._n_odom_lines = len(p.odom_lines) if p.odom_lines else len(self._stamps)

    @property
    def topics(self) -> list[TopicInfo]:
        """The scan, odometry and (if present) ground-truth streams, named as the converter writes them."""
        t = [
            TopicInfo("/scan", "sensor_msgs/msg/LaserScan", len(self._stamps)),
            TopicInfo("/odom", "nav_msgs/msg/Odometry", len(self._stamps)),
        ]
        if self._gt is not None:
            t.append(TopicInfo("/ground_truth", "nav_msgs/msg/Odometry", len(self._gt)))
        return t

    @property
    def scan_topic(self) -> str:
        """CARMEN logs have one front laser."""
        return "/scan"

    @property
    def odom_source(self) -> str:
        """Where the odometry comes from in this variant."""
        return {
            "carmen": "odometry pose on each scan line",
            "carmen-corrected": "raw odometry rebuilt from the re-anchored ODOM stream",
            "dpslam": "Odometry lines",
        }[self.format]

    @property
    def lidar_spec(self) -> LidarSpec:
        """The front laser."""
        return self._spec

    def time_range_ns(self) -> tuple[int, int]:
        """First and last scan stamp."""
        return int(self._stamps[0]), int(self._stamps[-1])

    def frames(self) -> Iterator[Frame]:
        """Every scan with its odometry pose."""
        for stamp, ranges, odom in zip(self._stamps, self._ranges, self._odom, strict=True):
            yield Frame(int(stamp), Scan(ranges, self._spec), Pose2D.from_array(odom))

    def ground_truth(self) -> Trajectory | None:
        """The corrected trajectory of a Radish corrected log (the laser poses on its scan lines)."""
        return self._gt

