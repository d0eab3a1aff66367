"""A :class:`~mcnkit.io.base.LogReader` over any raw message source (ROS1 bag, ROS2 bag folder, MCAP).

Detection (each overridable in :func:`mcnkit.io.open_log`):

* scan topic: the ``sensor_msgs/LaserScan`` topic named ``/scan``, else the one with the most messages; in a log with
  no LaserScan, the same among its ``sensor_msgs/MultiEchoLaserScan`` topics (read as their first echoes); a topic
  whose name says its scanner is vertical or tilted (a backpack's second scanner) comes after the others, and a log
  with several scan topics says which one it reads;
* odometry: the ``nav_msgs/Odometry`` topic named ``/odom``, else the busiest Odometry topic whose name does
  not look like ground truth; else the ``odom → base`` transform on ``/tf`` (``tf:<odom>-><base>``);
* the laser's mount: the chain of ``/tf_static`` transforms (else of fixed ones on ``/tf``) from the base frame to the
  scan's ``frame_id``, in 3-D: a scanner mounted upside down (its z axis pointing down) sweeps clockwise seen from
  above, so its ranges are read in reverse and its angles mirrored, and the planar frames look like any other.
  A log with odometry and no such chain (a bag recorded without ``/tf_static``) gets the scanner's direction, sense of
  sweep and offset from the robot's motion (:mod:`mcnkit.io.mountfit`) when they are plainly not facing forward,
  with a warning either way.

Frames: scans and odometry are read together in record order; each scan's odometry is interpolated at the
scan's header stamp between the two odometry poses around it.  A scan of another beam count or angles than the
scanner's (drivers of many 360° scanners change them every turn) is resampled onto its beams
(:func:`resample_beams`) and counted in one warning.  Scans whose stamp went backwards or whose header stamp is far
from their record time (:mod:`mcnkit.io.stampcheck`: one stamp
that jumped is dropped before it can hold up the scans behind it or make later odometry look as if it went
backwards) are skipped and counted in the one warning of :func:`mcnkit.io.plausible.plausible_frames`, which then
checks that every frame is physically plausible.

**Where odometry is missing** the motion is unknown, not zero: a scan farther than ``max_odom_gap_s`` from every
odometry sample (before the stream starts, after it ends, or in a gap of it) is a frame whose motion is unknown
(``Frame.odom_known`` False), and so is the first scan after such a stretch (its motion since the scan before is
unknown too); they are counted in one warning.  A log without any odometry (no Odometry topic, no odom->base
transform) gives frames that all say so: it is read lidar-only (:attr:`~mcnkit.io.base.LogReader.lidar_only`).
"""

from __future__ import annotations

import bisect
import math
import re
import warnings
from collections import Counter, deque
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from mcnkit.geometry import quaternion_to_yaw
from mcnkit.io.base import GroundTruthMap, LogReader, TopicInfo
from mcnkit.io.decode import MULTI_ECHO_TYPE, SCAN_TYPE, MessageDecoder
from mcnkit.io.errors import PARSE_ERRORS, LogError, LogWarning, as_log_error, warn_skipped
from mcnkit.io.plausible import MAX_RANGE_M, check_spec, plausible_frames, spec_problem
from mcnkit.io.sources import Connection, RawSource
from mcnkit.io.stampcheck import StampCheck
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan, Trajectory

__all__ = ["BagLog", "resample_beams"]

SCAN_TYPES = (SCAN_TYPE, MULTI_ECHO_TYPE)
ODOM_TYPE = "nav_msgs/msg/Odometry"
POSE_TYPES = (ODOM_TYPE, "geometry_msgs/msg/PoseStamped")
TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
MAP_TYPE = "nav_msgs/msg/OccupancyGrid"
_GT_NAME = re.compile(r"ground_?truth|(^|/)gt($|/|_)|truth", re.IGNORECASE)
_PENDING_NS = 10_000_000_000
_SPEC_SCANS = 5  # the scanner is what most of the first scans say
_MAX_SWEEP_S = 0.5  # the slowest spinning scanners turn twice a second; a longer "sweep" is not one


def resample_beams(ranges_m: np.ndarray, angle_min_rad: float, angle_increment_rad: float,
                   angles_rad: np.ndarray) -> np.ndarray:
    """A scan's readings (n,) at its own angles, put on other beam ``angles_rad`` (B,): each takes the reading of the
    beam nearest in angle (round the circle), within half a step of the coarser of the two; none that near: NaN
    (no return).  Readings are copied, never interpolated."""
    r = np.asarray(ranges_m, np.float32)
    n = len(r)
    if n == 0:
        return np.full(len(angles_rad), np.nan, np.float32)
    amin, inc = float(angle_min_rad), float(angle_increment_rad)
    if inc < 0:  # a clockwise scan, counter-clockwise from its last beam
        r, amin, inc = r[::-1], amin + (n - 1) * inc, -inc
    d = np.mod(np.asarray(angles_rad, np.float64) - amin, 2 * math.pi)  # [0, 2π) past the first beam
    last = np.minimum(np.rint(d / inc), n - 1).astype(np.int64) if inc > 0 else np.zeros(len(d), np.int64)
    err_last = np.abs(d - last * inc)
    err_first = 2 * math.pi - d  # round the circle to the first beam
    first = err_first < err_last
    index, err = np.where(first, 0, last), np.where(first, err_first, err_last)
    step = np.abs(np.diff(angles_rad)).min(initial=inc) if len(angles_rad) > 1 else inc
    out: np.ndarray = np.where(err <= 0.5 * max(inc, float(step)) + 1e-9, r[index], np.nan).astype(np.float32)
    return out


def _rotation(x: float, y: float, z: float, w: float) -> np.ndarray:
    """The rotation matrix (3, 3) of a quaternion (normalised here; a zero one is the identity)."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        return np.eye(3)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _time_increment(said_s: list[float], n_beams: int) -> float:
    """The time between beams the first scans say (their median, as drivers measure each sweep anew; negative: the
    beams were measured last to first), or 0 where it is not a sweep a scanner makes (not said, not finite, or a
    sweep longer than ``_MAX_SWEEP_S``)."""
    t = float(np.median(said_s)) if said_s else 0.0
    return t if math.isfinite(t) and 0.0 < abs(t) * (n_beams - 1) <= _MAX_SWEEP_S else 0.0


_SIDEWAYS = re.compile(r"vertical|tilt", re.IGNORECASE)


def _pick_scan(scans: list[TopicInfo]) -> str | None:
    """The scan topic to read: LaserScan before MultiEchoLaserScan, a scanner not named vertical or tilted before one
    that is, ``/scan`` first, then the busiest."""
    if not scans:
        return None
    return max(scans, key=lambda t: (t.msgtype == SCAN_TYPE, not _SIDEWAYS.search(t.name), t.name == "/scan",
                                     t.count)).name


def _pick(conns: list[TopicInfo], preferred: str) -> str | None:
    if not conns:
        return None
    names = [c.name for c in conns]
    return preferred if preferred in names else max(conns, key=lambda c: c.count).name


class BagLog(LogReader):
    """A ROS bag or MCAP log; see the module docstring for what is detected and how frames are built."""

    def __init__(
        self, path: Path, fmt: str, source: RawSource, *, scan_topic: str | None = None,
        odom: str | None = None, max_odom_gap_s: float = 0.25,
    ) -> None:
        self.path, self.format, self._src = path, fmt, source
        self._decoder = MessageDecoder()
        for c in source.connections:
            self._decoder.register(c.encoding, c.msgtype, c.definition, c.definition_format)
        self._max_gap_ns = int(max_odom_gap_s * 1e9)
        topics: dict[tuple[str, str], int] = {}
        for c in source.connections:
            topics[(c.topic, c.msgtype)] = topics.get((c.topic, c.msgtype), 0) + c.count
        self._topics = [TopicInfo(n, t, k) for (n, t), k in topics.items()]
        scans = [t for t in self._topics if t.msgtype in SCAN_TYPES]
        if scan_topic is not None and scan_topic not in {t.name for t in scans}:
            raise LogError(path, f"no LaserScan or MultiEchoLaserScan topic {scan_topic!r} (scan topics: "
                                 f"{[t.name for t in scans]})")
        self._scan_topic = scan_topic or _pick_scan(scans)
        if scan_topic is None and len(scans) > 1:
            others = sorted(t.name for t in scans if t.name != self._scan_topic)
            warnings.warn(f"{path}: {len(scans)} scan topics: reading {self._scan_topic} (not {', '.join(others)}; "
                          "--scan-topic chooses)", LogWarning, stacklevel=2)
        self._odom_source = self._detect_odom(odom)
        self._spec: LidarSpec | None = None
        self._upside_down = False  # the scanner is mounted upside down: its ranges are read in reverse
        self._geometry: tuple[float, float, int] | None = None  # the scanner's (angle_min, increment, beams) as logged
        self._resampled = 0  # scans of another geometry put on it (resample_beams)

    # -- detection ---------------------------------------------------------------------------------------
    def _detect_odom(self, override: str | None) -> str | None:
        odoms = [t for t in self._topics if t.msgtype == ODOM_TYPE]
        if override is not None:
            if override.startswith("tf:") or override in {t.name for t in odoms}:
                return override
            raise LogError(self.path, f"no Odometry topic {override!r} (Odometry topics: {[t.name for t in odoms]})")
        plain = [t for t in odoms if not _GT_NAME.search(t.name)]
        if plain:
            return _pick(plain, "/odom")
        for tf_topic in (t.name for t in self._topics if t.msgtype in TF_TYPES and t.name != "/tf_static"):
            for _, msg in self._take(tf_topic, 200):
                for tr in msg.transforms:
                    parent, child = tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/")
                    if "odom" in parent and "base" in child:
                        return f"tf:{parent}->{child}"
        return None

    def _take(self, topic: str, n: int) -> Iterator[tuple[int, Any]]:
        for i, item in enumerate(self.messages(topic)):
            if i >= n:
                return
            yield item

    def _mount_transforms(self) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
        """(parent, child) -> (rotation (3, 3), translation (3,)) of every transform on ``/tf_static``, and of those
        on ``/tf`` in its first messages that are not the odometry's or a map's (logs from before ``/tf_static``
        broadcast the fixed mounts there)."""
        out: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        tf_topics = sorted((t.name for t in self._topics if t.msgtype in TF_TYPES), key=lambda n: n != "/tf_static")
        for topic in tf_topics:
            static = topic == "/tf_static"
            for _, msg in (self.messages(topic) if static else self._take(topic, 200)):
                for tr in msg.transforms:
                    key = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
                    if not static and (key in out or any("odom" in f or "map" in f for f in key)):
                        continue
                    q, p = tr.transform.rotation, tr.transform.translation
                    out[key] = (_rotation(q.x, q.y, q.z, q.w), np.array([p.x, p.y, p.z], np.float64))
        return out

    def _odometry_child(self) -> str | None:
        """The base frame an Odometry topic names (its ``child_frame_id``), from its first readable message."""
        if not self._odom_source or self._odom_source.startswith("tf:"):
            return None
        for conn, _, raw in self._src.messages([self._odom_source]):
            try:
                return self._decoder.odometry(raw, conn.encoding).child_frame_id.lstrip("/") or None
            except PARSE_ERRORS:
                continue
        return None

    def _base_to_laser(self, laser_frame: str, facing_forward: LidarSpec) -> tuple[Pose2D, bool]:
        """The scanner's mount in the plane, and whether it is mounted upside down (its z axis points down: its
        beams sweep clockwise seen from above).  A log with odometry but no transform to the scanner's frame (a bag
        recorded without ``/tf_static``) gets the mount its motion shows (:meth:`_mount_from_motion`), with a
        warning."""
        base = self._base_frame()
        found = self._find_mount(laser_frame, base)
        if found is not None:
            return found
        if base is None or not laser_frame or laser_frame == base:
            return Pose2D(), False
        mount, upside_down, how = self._mount_from_motion(facing_forward)
        warn_skipped(self.path, f"no transform from the base frame {base!r} to the scanner's frame {laser_frame!r}: "
                                f"{how}")
        return mount, upside_down

    def _mount_from_motion(self, facing_forward: LidarSpec) -> tuple[Pose2D, bool, str]:
        """:func:`mcnkit.io.mountfit.mount_from_motion` on the log's frames as :meth:`frames` gives them, read with
        the scanner facing forward."""
        from mcnkit.io.mountfit import mount_from_motion  # numba, for the logs that need it only

        self._spec = facing_forward
        skipped: Counter[str] = Counter()
        frames = plausible_frames(self.path, self._read_frames(skipped), skipped)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", LogWarning)  # the frames are read again, and warn then
                return mount_from_motion(frames)
        except LogError:
            return Pose2D(), False, "the scanner is taken to sit at the base, facing forward"
        finally:
            frames.close()
            self._spec = None

    def _base_frame(self) -> str | None:
        """The robot's base frame as the odometry names it: the child of the ``/tf`` pair, or the Odometry topic's
        ``child_frame_id``; None without odometry."""
        if not self._odom_source:
            return None
        if "->" in self._odom_source:
            return self._odom_source.split("->")[1]
        return self._odometry_child()

    def _find_mount(self, laser_frame: str, base: str | None) -> tuple[Pose2D, bool] | None:
        """The mount from ``base`` through the log's transforms (see :meth:`_base_to_laser`; without odometry, or an
        Odometry child the transforms do not name: from the scanner's parent); None when no chain reaches it."""
        tfs = self._mount_transforms() if laser_frame else {}
        if not tfs:
            return None
        topic_base = not (self._odom_source or "").startswith("tf:")  # a /tf pair's child is the base the transforms hang from
        if base is None or (topic_base and not any(base in key for key in tfs)):
            base = next((p for (p, c) in tfs if c == laser_frame), None)
            if base is None:
                return None
        children: dict[str, list[tuple[str, tuple[np.ndarray, np.ndarray]]]] = {}
        for (p, c), tf in tfs.items():
            children.setdefault(p, []).append((c, tf))
        stack: list[tuple[str, np.ndarray, np.ndarray]] = [(base, np.eye(3), np.zeros(3))]
        seen = {base}
        while stack:
            frame, rot, trans = stack.pop()
            if frame == laser_frame:
                yaw = math.atan2(rot[1, 0], rot[0, 0])  # where the scanner's x axis points in the plane
                return Pose2D(float(trans[0]), float(trans[1]), yaw), bool(rot[2, 2] < 0)
            for child, (r, t) in children.get(frame, []):
                if child not in seen:
                    seen.add(child)
                    stack.append((child, rot @ r, trans + rot @ t))
        return None

    # -- LogReader ----------------------------------------------------------------------------------------
    @property
    def compression(self) -> str | None:
        """The source's (:attr:`mcnkit.io.sources.RawSource.compression`)."""
        return self._src.compression

    @property
    def topics(self) -> list[TopicInfo]:
        """Every topic with its type and count."""
        return list(self._topics)

    @property
    def scan_topic(self) -> str:
        """The LaserScan topic ('' if the log has none)."""
        return self._scan_topic or ""

    @property
    def odom_source(self) -> str:
        """The odometry source ('' if none was found)."""
        return self._odom_source or ""

    def _require_scan(self) -> str:
        if not self._scan_topic:
            raise LogError(self.path, "no sensor_msgs/LaserScan (or MultiEchoLaserScan) topic (topics: "
                                      f"{[t.name for t in self._topics]})")
        return self._scan_topic

    @property
    def lidar_spec(self) -> LidarSpec:
        """From the first scan; the mount from /tf_static."""
        with as_log_error(self.path, "damaged first scan"):
            return self._lidar_spec()

    def _lidar_spec(self) -> LidarSpec:
        if self._spec is None:
            topic = self._require_scan()
            sweeps: dict[tuple[float, float, int, float, float, str], list[float]] = {}  # per geometry, its scans'
            problems = []
            unstated: float | None = None  # a range_max that states no range
            for conn, _, raw in self._src.messages([topic]):
                try:
                    s = self._decoder.scan(raw, conn.encoding, conn.msgtype)
                except PARSE_ERRORS:
                    continue
                rmin, rmax = float(s.range_min_m), float(s.range_max_m)
                rmin = rmin if math.isfinite(rmin) and rmin > 0.0 else 0.0
                if not (math.isfinite(rmax) and rmin < rmax <= MAX_RANGE_M):
                    unstated = rmax  # inf, NaN, 0 or FLT_MAX: every finite reading from range_min on is a return
                    rmin, rmax = (rmin, MAX_RANGE_M) if rmin < MAX_RANGE_M else (0.0, MAX_RANGE_M)
                key = (float(s.angle_min_rad), float(s.angle_increment_rad), len(s.ranges_m), rmin, rmax,
                       s.frame_id.lstrip("/"))
                problem = spec_problem(LidarSpec(*key[:3], 0.0, 1.0)) if key[2] > 0 else "no beams"
                if problem is None and not 0.0 <= key[3] < key[4]:
                    problem = f"range interval [{key[3]!r}, {key[4]!r}] m"
                if problem is None:
                    problem = spec_problem(LidarSpec(*key[:5]))
                if problem is None:
                    sweeps.setdefault(key, []).append(float(s.time_increment_s))
                else:
                    problems.append(problem)
                if sum(map(len, sweeps.values())) + len(problems) >= _SPEC_SCANS:
                    break
            if not sweeps:
                if problems:
                    raise LogError(self.path, f"implausible scanner: {problems[0]}")
                raise LogError(self.path, f"LaserScan topic {topic} has no (readable) messages")
            key = max(sweeps, key=lambda k: len(sweeps[k]))  # the commonest geometry (the first of a tie)
            if unstated is not None and key[4] == MAX_RANGE_M:
                warnings.warn(f"{self.path}: {topic} states no range (range_max {unstated!r}): every finite reading "
                              f"from {key[3]:g} m up to {MAX_RANGE_M:g} m is a return", LogWarning, stacklevel=2)
            amin, inc, n = key[:3]
            self._geometry = (amin, inc, n)
            mount, self._upside_down = self._base_to_laser(key[5], check_spec(self.path, LidarSpec(*key[:5])))
            between = _time_increment(sweeps[key], n)
            if self._upside_down:  # beam i at −(amin + i·inc): the reversed scan starts at −angle_max
                amin, between = -(amin + (n - 1) * inc), -between  # and its first beam was measured last
            self._spec = check_spec(self.path, LidarSpec(amin, inc, n, *key[3:5], mount, between))
        return self._spec

    def time_range_ns(self) -> tuple[int, int]:
        """Record times of the first and last message."""
        with as_log_error(self.path, "damaged data while finding the time range"):
            return self._src.time_range_ns()

    def messages(self, topic: str) -> Iterator[tuple[int, Any]]:
        """Decoded messages of ``topic``."""
        with as_log_error(self.path, f"cannot decode a message on {topic}"):
            for conn, t, raw in self._src.messages([topic]):
                yield t, self._decoder.decode(raw, conn.msgtype, conn.encoding)

    def _odom_samples(self, conn: Connection, t: int, raw: bytes | memoryview) -> list[tuple[int, float, float, float]]:
        if conn.msgtype == ODOM_TYPE:
            o = self._decoder.odometry(raw, conn.encoding)
            return [(o.stamp_ns or t, o.x_m, o.y_m, o.yaw_rad)]
        parent, child = self.odom_source[3:].split("->")
        out = []
        for tr in self._decoder.decode(raw, conn.msgtype, conn.encoding).transforms:
            if tr.header.frame_id.lstrip("/") == parent and tr.child_frame_id.lstrip("/") == child:
                q, p = tr.transform.rotation, tr.transform.translation
                stamp = int(tr.header.stamp.sec) * 1_000_000_000 + int(tr.header.stamp.nanosec)
                out.append((stamp or t, p.x, p.y, float(quaternion_to_yaw(np.array([q.x, q.y, q.z, q.w])))))
        return out

    def _read_frames(self, skipped: Counter[str]) -> Generator[Frame, None, None]:
        """Time-ordered frames (see the module docstring); what is skipped is counted into ``skipped``."""
        with as_log_error(self.path, "damaged data while reading frames"):
            yield from self._frames(skipped)

    def _decoded_scan(self, conn: Connection, t: int, raw: bytes | memoryview) -> tuple[int, np.ndarray] | None:
        """A scan's stamp and readings on the scanner's beams: one of another beam count or angles (a driver that
        does not keep them constant, as many 360° scanners' do not) is resampled onto them (once the scanner is
        known), and an upside-down scanner's readings are reversed."""
        try:
            s = self._decoder.scan(raw, conn.encoding, conn.msgtype)
        except PARSE_ERRORS:
            return None
        ranges = s.ranges_m
        if self._geometry is not None:
            amin, inc, n = self._geometry
            far_end = (len(ranges) - 1) * s.angle_increment_rad - (n - 1) * inc
            if len(ranges) != n or abs(s.angle_min_rad - amin) > abs(inc) / 4 or abs(far_end) > abs(inc) / 4:
                ranges = resample_beams(ranges, s.angle_min_rad, s.angle_increment_rad, amin + inc * np.arange(n))
                self._resampled += 1
        return s.stamp_ns or t, ranges[::-1].copy() if self._upside_down else ranges

    def _decoded_odom(self, conn: Connection, t: int, raw: bytes | memoryview) -> list[tuple[int, float, float, float]] | None:
        try:
            return self._odom_samples(conn, t, raw)
        except PARSE_ERRORS:
            return None

    def _stamp_checks(self, scan_topic: str, odom_topic: str) -> tuple[StampCheck, StampCheck]:
        """Header stamps against record times, seeded with the first messages of each stream."""
        scans, odoms = StampCheck(), StampCheck()
        for conn, t, raw in self._src.messages([scan_topic]):
            if (s := self._decoded_scan(conn, t, raw)) is not None and scans.seed(s[0] - t):
                break
        for conn, t, raw in self._src.messages([odom_topic]):
            if any(odoms.seed(sample[0] - t) for sample in self._decoded_odom(conn, t, raw) or []):
                break
        return scans, odoms

    def _frames(self, skipped: Counter[str]) -> Iterator[Frame]:
        self.check_frames()
        scan_topic = self._require_scan()
        spec = self.lidar_spec
        if not self.odom_source:
            yield from self._scan_only_frames(scan_topic, spec, skipped)
            return
        odom_topic = "/tf" if self.odom_source.startswith("tf:") else self.odom_source
        scan_check, odom_check = self._stamp_checks(scan_topic, odom_topic)
        self._resampled = 0  # the stamp checks read a few scans ahead
        odom_t: deque[int] = deque(maxlen=256)
        odom_p: deque[tuple[float, float, float]] = deque(maxlen=256)
        pending: deque[tuple[int, np.ndarray, int]] = deque()  # (stamp, ranges, record time)
        last = Pose2D()  # the odometry of the last frame (repeated by a frame whose motion is unknown)
        gap = False  # the last frame had no odometry: the next one's motion is unknown too
        unknown = frames = 0

        def emit(stamp: int, ranges: np.ndarray, _t: int) -> Frame:
            nonlocal last, gap, unknown, frames
            pose = self._odometry_at(stamp, odom_t, odom_p)
            frames += 1
            if pose is None:
                unknown += 1
                gap = True
                return Frame(stamp, Scan(ranges, spec), last, False)
            known, gap = not gap, False
            unknown += not known
            last = Pose2D(*pose)
            return Frame(stamp, Scan(ranges, spec), last, known)

        for conn, t, raw in self._src.messages([scan_topic, odom_topic]):
            if conn.topic == scan_topic:
                s = self._scan_ok(conn, t, raw, spec.n_beams, scan_check, skipped)
                if s is not None:
                    pending.append((s[0], s[1], t))
            else:
                samples = self._decoded_odom(conn, t, raw)
                if samples is None:
                    skipped["damaged odometry message"] += 1
                for sample in samples or []:
                    if not odom_check.ok(sample[0] - t):
                        skipped["odometry stamp far from its record time"] += 1
                    elif odom_t and sample[0] <= odom_t[-1]:
                        if sample[0] < odom_t[-1]:
                            skipped["odometry stamp went backwards"] += 1
                        # odometry stamps must increase; a repeated or older sample adds nothing
                    else:
                        odom_t.append(sample[0])
                        odom_p.append(sample[1:])
            # a scan waits for the odometry after its stamp, but not for longer than _PENDING_NS of the log
            while pending and ((odom_t and odom_t[-1] >= pending[0][0]) or t - pending[0][2] > _PENDING_NS):
                yield emit(*pending.popleft())
        while pending:
            yield emit(*pending.popleft())
        if unknown:
            warn_skipped(self.path, f"no odometry within {self._max_gap_ns / 1e9:g} s of {unknown} of {frames} scans "
                                    "(or just after such a stretch): read as unknown motion")
        self._warn_resampled()

    def _warn_resampled(self) -> None:
        if self._resampled:
            warn_skipped(self.path, f"{self._resampled} scans of another beam count or angles than the scanner's "
                                    f"{self.lidar_spec.n_beams} beams: resampled onto them by angle")
            self._resampled = 0

    def _odometry_at(self, stamp: int, odom_t: deque[int], odom_p: deque[tuple[float, float, float]]
                     ) -> tuple[float, float, float] | None:
        """The odometry interpolated at ``stamp`` (None: no sample within ``max_odom_gap_s``)."""
        n = len(odom_t)
        if n == 0:
            return None
        if n >= 2 and odom_t[-2] <= stamp <= odom_t[-1]:  # the usual case: the last two samples bracket it
            i = n - 1
        else:
            i = bisect.bisect_left(odom_t, stamp)
        if i == 0:
            return odom_p[0] if odom_t[0] - stamp <= self._max_gap_ns else None
        if i == n:
            return odom_p[-1] if stamp - odom_t[-1] <= self._max_gap_ns else None
        t0, t1 = odom_t[i - 1], odom_t[i]
        if min(stamp - t0, t1 - stamp) > self._max_gap_ns and t1 - t0 > 2 * self._max_gap_ns:
            return None  # a gap in the odometry stream
        (x0, y0, a0), (x1, y1, a1) = odom_p[i - 1], odom_p[i]
        u = (stamp - t0) / (t1 - t0)
        da = (a1 - a0 + math.pi) % (2 * math.pi) - math.pi
        a = (a0 + u * da + math.pi) % (2 * math.pi) - math.pi
        return x0 + u * (x1 - x0), y0 + u * (y1 - y0), a

    def _scan_ok(self, conn: Connection, t: int, raw: bytes | memoryview, n_beams: int, check: StampCheck,
                 skipped: Counter[str]) -> tuple[int, np.ndarray] | None:
        """A scan's stamp and ranges, or None (counted in ``skipped``) when it cannot be a frame."""
        s = self._decoded_scan(conn, t, raw)
        if s is None:
            skipped["damaged message"] += 1
        elif len(s[1]) != n_beams:
            skipped["different beam count"] += 1
        elif not check.ok(s[0] - t):
            skipped["stamp far from its record time"] += 1
        else:
            return s
        return None

    def _scan_only_frames(self, scan_topic: str, spec: LidarSpec, skipped: Counter[str]) -> Iterator[Frame]:
        """A log without odometry: every frame's motion is unknown (its odometry the origin)."""
        check = StampCheck()
        for conn, t, raw in self._src.messages([scan_topic]):
            if (s := self._decoded_scan(conn, t, raw)) is not None and check.seed(s[0] - t):
                break
        self._resampled = 0
        origin = Pose2D()
        for conn, t, raw in self._src.messages([scan_topic]):
            if (s := self._scan_ok(conn, t, raw, spec.n_beams, check, skipped)) is not None:
                yield Frame(s[0], Scan(s[1], spec), origin, False)
        self._warn_resampled()

    def ground_truth(self) -> Trajectory | None:
        """Poses from a topic whose name says ground truth (Odometry or PoseStamped)."""
        topic = next((t.name for t in self._topics if t.msgtype in POSE_TYPES and _GT_NAME.search(t.name)), None)
        if topic is None:
            return None
        stamps, poses = [], []
        for t, m in self.messages(topic):
            pose = m.pose.pose if hasattr(m.pose, "pose") else m.pose
            q = pose.orientation
            stamps.append(int(m.header.stamp.sec) * 1_000_000_000 + int(m.header.stamp.nanosec) or t)
            poses.append((pose.position.x, pose.position.y, float(quaternion_to_yaw(np.array([q.x, q.y, q.z, q.w])))))
        if not stamps:
            return None
        return Trajectory(np.asarray(stamps, dtype=np.int64), np.asarray(poses, dtype=np.float64))

    def ground_truth_map(self) -> GroundTruthMap | None:
        """The last message of the OccupancyGrid topic (a ground-truth-named one first)."""
        maps = [t for t in self._topics if t.msgtype == MAP_TYPE and t.count]
        if not maps:
            return None
        topic = next((t.name for t in maps if _GT_NAME.search(t.name)), maps[0].name)
        last = None
        for _, m in self.messages(topic):
            last = m
        if last is None:
            return None
        info = last.info
        data = np.asarray(last.data, dtype=np.int8).reshape(int(info.height), int(info.width))
        stamp = int(last.header.stamp.sec) * 1_000_000_000 + int(last.header.stamp.nanosec)
        return GroundTruthMap(stamp, round(float(info.resolution), 6), float(info.origin.position.x),  # float32 field
                              float(info.origin.position.y), data)

    def close(self) -> None:
        """Closes the underlying files."""
        self._src.close()
