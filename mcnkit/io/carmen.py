"""CARMEN logs (``.clf``, ``.log``, gzip'd or not) in every dialect their tools wrote, and DP-SLAM logs.

Lines understood (anything after the fields listed is optional: logs written by gmapping's and older CARMEN
tools drop the host and logger stamp, or all three stamp fields):

* ``FLASER n r1..rn x y theta odom_x odom_y odom_theta [ipc_timestamp host logger_timestamp]``: the front laser,
  180° wide from -90°: 181/361/721 beams span -90..+90°, other counts (180, 360) use steps of 180°/n (-90..+89°
  for 180 beams, as in the Intel lab log).  ``RLASER``: the rear laser, same layout.  A line that carries only
  one pose (``x y theta``) uses it as odometry too.
* ``ROBOTLASER1``/``ROBOTLASER2 type start_angle fov resolution max_range accuracy remission_mode n r1..rn
  m e1..em laser_x laser_y laser_theta robot_x robot_y robot_theta [tv rv fwd side turn ts host logger_ts]``.
* ``RAWLASER1``..``RAWLASER4 type start_angle fov resolution max_range accuracy remission_mode n r1..rn m e1..em
  [ts host logger_ts]``: no pose; odometry comes from the ``ODOM`` stream (interpolated at the scan's stamp, or
  the last ``ODOM`` line before the scan when stamps cannot be trusted).
* ``ODOM x y theta [tv rv accel ts host logger_ts]``.
* DP-SLAM's ``Odometry x y theta`` and ``Laser n r1..rn`` (181 beams -90..+90°, no timestamps).
* ``PARAM``, ``SYNC``, ``NEFF``, ``TRUEPOS`` and ``#`` comment lines are recognised and not needed.

The scans are the front laser's (``FLASER``, ``ROBOTLASER1`` or ``RAWLASER1``, whichever the log has most of),
else the rear laser's, else DP-SLAM's.  A line is skipped only when its fields cannot be parsed (a declared beam
count the line does not hold, a word where a number must be); the skipped lines are counted in one warning and
:attr:`CarmenLog.laser_lines` says how many laser lines the log holds.

**Stamps.**  Frames always come in log order, one per laser line read.  Their stamps are the lines' IPC stamps,
exact to the nanosecond as printed, when those rise strictly.  Otherwise one warning says what was wrong and the
stamps are rebuilt, in log order:

* stamps that only tie or step back a little (clock jitter, or stamps printed with six significant digits such as
  ``1.13486e+09``, i.e. ten-second ticks) keep their time: each run of equal (or earlier) stamps is spread evenly
  up to the next later stamp;
* stamps that carry no time at all (all equal, all zero, negative, the 32-bit sentinel ``4.29497e+09``, not
  numbers, or going back more often than forward) are replaced: by the stamp of the ``ODOM`` line each scan
  follows when the odometry stream's stamps rise, else at a nominal ``period_s`` per scan.

**Odometry per scan** is the odometry pose logged on the scan line.  The Radish "corrected" variant (the Intel lab
log) is recognised by its ``ODOM`` stream re-anchored at each scan's pose: there the scan line holds the
SLAM-corrected pose (kept as ground truth) and the raw odometry is rebuilt by chaining
``inverse(corrected_k) ⊕ (last ODOM pose before scan k+1)``, starting from the first corrected pose.

**Motion no robot makes**: where a scan's stamp had to be rebuilt, its stamps carry no time to judge a speed by,
so an odometry step into or out of it longer than ``STEP_SLACK_M`` (2 m), or four times the log's median step
where that is longer (:func:`~mcnkit.io.carmen_scans.untimed_step_limit_m`), is read as unknown motion
(``Frame.odom_known`` False), counted in one warning: a misparsed line must not carry the robot 20 m between two
scans.  Its turn is not judged: without time, a robot may turn in place by any angle between two scans.  Other steps are judged by :mod:`mcnkit.io.plausible` from the stamps.

**Memory**: the log is read line by line, twice (once to find the scanner, the stamps and the odometry, once per
pass over the frames), holding about 80 bytes per laser line and 32 per ``ODOM`` line, and the readings only
while they fit in 32 MiB (then each pass over the frames parses the laser lines again).  A line longer than
``MAX_LINE_BYTES`` is refused; gzip'd logs are decompressed as they are read, within ``MAX_RATIO``.

**"No return"**: these logs mark it with sentinels at the top of the range (81.91, 81.83, 50.00, 51.15 or 8.191 m,
sometimes several in one log).  A 1 cm bin of readings within the top 10 % of the span that holds more than
0.05 % of all readings (and at least 20) is a sentinel, and the scanner's ``range_max_m`` is set 2 cm below the
smallest one; otherwise ``range_max_m`` is the largest reading.

**Every line stays reachable**: :meth:`CarmenLog.messages` gives the decoded streams (``/scan``: :class:`Scan`,
``/odom`` and ``/ground_truth``: :class:`Pose2D`, at the frames' stamps) and, by keyword (``FLASER``, ``ODOM``,
``PARAM``, ``NEFF``, ...; :attr:`CarmenLog.keywords` counts them), every line of that type as a
:class:`CarmenRecord`, in log order.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import relative, wrap_angle
from mcnkit.io.base import LogReader, TopicInfo
from mcnkit.io.carmen_parse import (
    CarmenRecord,
    choose_source,
    is_carmen,
    keyword,
    line_stamp,
    lines,
    parse,
    read_ranges,
    stats_of,
)
from mcnkit.io.carmen_scans import (
    RangeStats,
    impossible_steps,
    is_corrected_variant,
    odometry_from_stream,
    rebuild_raw_odometry,
)
from mcnkit.io.carmen_stamps import repair_stamps
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.io.plausible import check_spec
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan, Trajectory

__all__ = ["CarmenLog", "CarmenRecord", "is_carmen", "repair_stamps"]


class CarmenLog(LogReader):
    """A CARMEN or DP-SLAM log, read line by line (see the module docstring).

    Args:
        path: the log.
        period_s: seconds between scans when the log's stamps carry no time (DP-SLAM logs have none).
    """

    def __init__(self, path: Path, period_s: float = 0.2) -> None:
        self.path = path
        p = parse(path)
        key = choose_source(p)
        if key is None or not p.tables.get(key):
            skipped = sum(p.skipped.values())
            why = f" ({skipped} laser line(s) could not be parsed)" if skipped else ""
            raise LogError(path, f"no laser scans (FLASER, RLASER, ROBOTLASER, RAWLASER or Laser lines) in this "
                                 f"CARMEN log{why}")
        table = p.tables[key]
        self.laser_lines = len(table) + p.skipped.get(key, 0)
        """Laser lines of the chosen laser in the log (read or not)."""
        self.laser_keyword = key
        groups = table.group_counts()
        group = groups.most_common(1)[0][0]
        n_beams, geometry = group
        rows = np.arange(len(table))
        if len(groups) > 1:
            n_other = sum(c for b, c in groups.items() if b != group)
            warn_skipped(path, f"{n_other} {key} line(s) with another beam count or geometry than the {n_beams} beams "
                               "of the rest skipped")
            rows = table.rows_of(group)
        if p.skipped:
            parts = ", ".join(f"{c} {k} (first at line {p.first_skipped[k]})" for k, c in p.skipped.items())
            warn_skipped(path, f"malformed line(s) skipped: {parts}")
        self.format = "dpslam" if key == "Laser" else "carmen"
        self._lines = table.ints(table.lines, rows)
        odom_index = table.ints(table.odom_index, rows)
        odom_stamps = p.odom.stamp_array()
        odom_ok = len(odom_stamps) > 1 and bool((odom_stamps > 0).all()) and bool((np.diff(odom_stamps) > 0).all())
        fallback = odom_stamps[np.maximum(odom_index, 0)] + 1 if odom_ok else None
        given = table.stamp_list(rows)
        stamps, problem = repair_stamps(given, fallback, period_s)
        if problem is not None and self.format != "dpslam":
            warn_skipped(path, problem)
        rebuilt = np.array([g is None or g != s for g, s in zip(given, stamps.tolist(), strict=True)], dtype=bool)
        self._gt: Trajectory | None = None
        self._keywords: dict[str, int] | None = None
        odom_known = np.ones(len(rows), dtype=bool)
        has_odom = not key.startswith("RAWLASER")
        poses = table.array3(table.poses, rows) if has_odom else None
        self._no_odometry = False
        if self.format == "carmen" and is_corrected_variant(poses, table.ints(table.first_odom_after, rows), p.odom):
            assert poses is not None
            self.format = "carmen-corrected"
            odom, bad, odom_known = rebuild_raw_odometry(poses, odom_index, p.odom, stamps, rebuilt)
            if bad:
                warn_skipped(path, f"{bad} odometry increment(s) a robot cannot make (damaged numbers?) read as "
                                   "unknown motion")
            if gaps := int((~odom_known).sum()) - bad:
                warn_skipped(path, f"no odometry between {gaps} of {len(rows) - 1} pairs of consecutive scans: "
                                   "read as unknown motion (searched for by scan matching)")
            gt_poses = poses.copy()
            gt_poses[:, 2] = wrap_angle(gt_poses[:, 2])
            self._gt = Trajectory(stamps.copy(), gt_poses)
        elif not has_odom:
            self._no_odometry = len(p.odom) == 0
            odom = np.zeros((len(rows), 3)) if self._no_odometry else odometry_from_stream(
                path, stamps, odom_index, p.odom, odom_stamps if odom_ok and problem is None else None)
            odom_known[:] = not self._no_odometry
        else:
            odom = table.array3(table.odoms, rows)
        odom[:, 2] = wrap_angle(odom[:, 2])  # logs hold headings outside [-pi, pi)
        jumps = impossible_steps(odom, rebuilt) & odom_known if self.format != "carmen-corrected" else None
        if jumps is not None and jumps.any():
            odom_known &= ~jumps
            warn_skipped(path, f"{int(jumps.sum())} odometry step(s) a robot cannot make between scans whose stamps were rebuilt "
                               "(damaged lines?) read as unknown motion")
        self._stamps = stamps
        self._odom = odom
        self._odom_known = odom_known
        stats = p.stats.get((key, group)) or stats_of(path, key, self._lines)
        if stats.nonfinite:  # CARMEN writes numbers: nan / inf are damage
            warn_skipped(path, f"{stats.nonfinite} range reading(s) in {stats.rows_nonfinite} scan(s) are not numbers "
                               "(nan / inf): read as no return")
        cached = p.cache.get(key) if p.cache is not None else None
        self._ranges = [cached[i] for i in rows.tolist()] if cached is not None else None
        amin, inc, max_range = geometry
        self._spec = check_spec(path, _spec(path, self.format, table.array3(table.poses, rows[:1]),
                                            table.array3(table.odoms, rows[:1]), (amin, inc, n_beams), max_range, stats))

    @property
    def topics(self) -> list[TopicInfo]:
        """The scan, odometry and (if present) ground-truth streams, named as the converter writes them."""
        t = [TopicInfo("/scan", "sensor_msgs/msg/LaserScan", len(self._stamps))]
        if not self._no_odometry:
            t.append(TopicInfo("/odom", "nav_msgs/msg/Odometry", len(self._stamps)))
        if self._gt is not None:
            t.append(TopicInfo("/ground_truth", "nav_msgs/msg/Odometry", len(self._gt)))
        return t

    @property
    def scan_topic(self) -> str:
        """CARMEN logs are read as one scan stream."""
        return "/scan"

    @property
    def odom_source(self) -> str:
        """Where the odometry comes from in this variant ('' for RAWLASER lines without an ODOM stream)."""
        if self.format == "carmen-corrected":
            return "raw odometry rebuilt from the re-anchored ODOM stream"
        if self.format == "dpslam":
            return "Odometry lines"
        if self.laser_keyword.startswith("RAWLASER"):
            return "" if self._no_odometry else "ODOM lines at the scan stamps"
        return f"odometry pose on each {self.laser_keyword} line"

    @property
    def lidar_spec(self) -> LidarSpec:
        """The laser the frames come from."""
        return self._spec

    def time_range_ns(self) -> tuple[int, int]:
        """First and last scan stamp."""
        return int(self._stamps[0]), int(self._stamps[-1])

    def _read_frames(self, skipped: Counter[str]) -> Iterator[Frame]:
        """Every scan read, in log order, with its odometry pose."""
        ranges = self._ranges if self._ranges is not None else read_ranges(self.path, self.laser_keyword, self._lines)
        for stamp, r, odom, known in zip(self._stamps, ranges, self._odom, self._odom_known, strict=True):
            yield Frame(int(stamp), Scan(r, self._spec), Pose2D.from_array(odom), bool(known))

    def ground_truth(self) -> Trajectory | None:
        """The corrected trajectory of a Radish corrected log (the laser poses on its scan lines)."""
        return self._gt

    @property
    def keywords(self) -> dict[str, int]:
        """How many lines of each keyword the log holds (``#`` comments not counted), in order of first use."""
        if self._keywords is None:
            counts: dict[str, int] = {}
            for line in lines(self.path):
                word = keyword(line)
                if word and not word.startswith("#"):
                    counts[word] = counts.get(word, 0) + 1
            self._keywords = counts
        return self._keywords

    def messages(self, topic: str) -> Iterator[tuple[int, Any]]:
        """``(stamp ns, message)`` pairs of one stream, in log order (nothing for a topic the log does not hold).

        ``/scan`` gives each frame's :class:`Scan`, ``/odom`` its odometry :class:`Pose2D` and ``/ground_truth``
        the corrected pose (Radish corrected logs), at the frames' stamps.  A keyword (``FLASER``, ``ODOM``,
        ``PARAM``, ``NEFF``, ...) gives every line of that type as a :class:`CarmenRecord`, malformed ones included;
        the stamp is the line's own IPC stamp, else the last one before it in the log (0 before the first)."""
        if topic == "/scan":
            for frame in self.frames():
                yield frame.stamp_ns, frame.scan
        elif topic == "/odom":
            for frame in self.frames():
                yield frame.stamp_ns, frame.odom
        elif topic == "/ground_truth":
            if self._gt is not None:
                for stamp, pose in zip(self._gt.stamps_ns, self._gt.poses, strict=True):
                    yield int(stamp), Pose2D.from_array(pose)
        else:
            last = 0
            for lineno, line in enumerate(lines(self.path), start=1):
                tok = line.split()
                if not tok:
                    continue
                stamp = line_stamp(tok)
                last = stamp if stamp is not None else last
                if tok[0] == topic:
                    yield last, CarmenRecord(tok[0], tuple(tok[1:]), lineno, stamp)


def _spec(path: Path, fmt: str, pose: NDArray[np.float64], odom: NDArray[np.float64],
          beams: tuple[float, float, int], max_range: float, stats: RangeStats) -> LidarSpec:
    """The scanner: the geometry of its lines, its range limit (from the readings when the lines give none) and the
    mount offset the first line's laser pose and robot pose give (plain CARMEN logs)."""
    amin, inc, n = beams
    offset = np.zeros(3)
    if fmt == "carmen" and not np.isnan(pose).any() and not np.isnan(odom).any():
        offset = np.round(relative(odom[0], pose[0]), 9)
        if not np.isfinite(offset).all() or np.hypot(offset[0], offset[1]) > 2.0:  # not a mount offset
            offset = np.zeros(3)
    offset += 0.0  # no negative zeros
    rmax = stats.range_max() if math.isinf(max_range) else max_range
    try:
        return LidarSpec(amin, inc, int(n), 0.0, rmax, Pose2D.from_array(offset))
    except ValueError as err:
        raise LogError(path, f"implausible scanner: {err}") from err
