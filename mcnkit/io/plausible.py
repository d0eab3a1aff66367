"""Physical plausibility at the frame boundary: what a reader hands to SLAM is something a robot could have seen.

Every :class:`~mcnkit.io.base.LogReader` yields its frames through :func:`plausible_frames`, so the rules below
hold for every format.  Checksums (MCAP chunk CRCs, sqlite's own checks) catch damage where a format has them;
these rules catch what gets past them (ROS1 bags and CARMEN text carry no checksums).  What fails is dropped and
counted in ONE warning per pass over the frames; a log with no usable frame left is refused with one line.

**The scanner** (:func:`spec_problem`, checked once per log: a bad one refuses the log): 1 to ``MAX_BEAMS``
beams; finite ``angle_min`` within ±2π; a finite, non-zero angle increment with a field of view of at most 360°;
``0 <= range_min < range_max <= MAX_RANGE_M`` (1 km: farther than any planar scanner measures).

**A scan** (:func:`ranges_problem`) is dropped only when it cannot be one of its scanner's: another beam count.
Every reading outside ``[range_min, range_max]`` is "no return" (ROS REP 117): NaN a failed measurement, +inf
nothing within range, -inf too close, a finite reading beyond ``range_max`` (SICK's 81.91 m on an 81.89 m
scanner, CARMEN's sentinels, an RPLIDAR's returns past its stated limit) or below ``range_min`` (negative ones
included); :attr:`mcnkit.types.Scan.valid` says which readings are returns, and the readings are passed on as
logged, so a conversion keeps them.  The mount offset of the scanner on the base is finite and within
``MAX_MOUNT_M`` (100 m).

**Stamps**: 0 <= stamp < 2^32 s (every ROS time fits).  A scan stamped before the last one passed on is dropped
("stamp went backwards"); a scan stamped after most of the next ``LOOKAHEAD`` scans (which themselves follow
the last one passed on) is dropped too ("stamp out of order": one stamp that jumped ahead must not make every
later scan look like it went backwards).

**Odometry**: finite, within ``MAX_COORD_M`` (10 000 km) of the origin.  Between two scans ``dt`` seconds apart
a robot moves at most ``MAX_SPEED_M_S · dt + STEP_SLACK_M`` metres and turns at most ``MAX_TURN_RAD_S · dt +
TURN_SLACK_RAD`` radians: 10 m/s (36 km/h, beyond any indoor robot, a car in town) and a full turn per second,
plus 2 m and 1 rad for stamps that are coarse or rebuilt (CARMEN logs restamped at a nominal rate; MIT CSAIL's
raw odometry has 0.9 m steps within 0.21 s, the Intel log turns 0.6 rad between scans restamped 10 ms apart).
A step beyond that is resolved with the next ``LOOKAHEAD`` scans:

* if one of them is again within reach of the last scan passed on, the scan was an outlier: dropped;
* if they all follow on from it instead (the odometry jumped and stayed there: a reset, or one damaged
  increment of odometry that is rebuilt by chaining), the odometry is re-anchored: from that scan on, poses are
  moved rigidly so that the pose repeats across the jump, and that frame says its motion is unknown
  (``Frame.odom_known`` False: SLAM's scan matching searches for the real one);
* otherwise the scan is dropped (and when it carried unknown motion, so does the next frame, whose motion
  now spans it).

A frame the reader already marks as unknown motion (a gap in the odometry, a log without odometry, a step the
reader found impossible) is not judged by these rules: its odometry is re-anchored to repeat the last pose passed
on (unless it already does), so that the motion it carries is none and the poses after it keep their increments.

Poses are passed on bit for bit unless a re-anchoring happened.  :func:`without_odometry` reads any log as one
without odometry (every frame's motion unknown, its pose the origin).
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Generator, Iterable, Iterator
from itertools import pairwise
from pathlib import Path

import numpy as np

from mcnkit.geometry import compose, inverse
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.types import Frame, LidarSpec, Pose2D

__all__ = [
    "LOOKAHEAD",
    "MAX_BEAMS",
    "MAX_COORD_M",
    "MAX_MOUNT_M",
    "MAX_RANGE_M",
    "MAX_SPEED_M_S",
    "MAX_STAMP_NS",
    "MAX_TURN_RAD_S",
    "STEP_SLACK_M",
    "TURN_SLACK_RAD",
    "check_spec",
    "plausible_frames",
    "pose_problem",
    "ranges_problem",
    "spec_problem",
    "step_possible",
    "without_odometry",
]

MAX_BEAMS = 100_000
MAX_RANGE_M = 1000.0
MAX_MOUNT_M = 100.0
MAX_STAMP_NS = 2**32 * 1_000_000_000
MAX_COORD_M = 1e7
MAX_SPEED_M_S = 10.0
MAX_TURN_RAD_S = 2.0 * math.pi
STEP_SLACK_M = 2.0
TURN_SLACK_RAD = 1.0
LOOKAHEAD = 3

_TWO_PI = 2.0 * math.pi


def spec_problem(spec: LidarSpec) -> str | None:
    """What makes a scanner description impossible (None: nothing)."""
    if not 1 <= spec.n_beams <= MAX_BEAMS:
        return f"{spec.n_beams} beams (a scanner has 1 to {MAX_BEAMS})"
    if not (math.isfinite(spec.angle_min_rad) and abs(spec.angle_min_rad) <= _TWO_PI):
        return f"first beam angle {spec.angle_min_rad!r} rad"
    inc = spec.angle_increment_rad
    if not (math.isfinite(inc) and inc != 0.0 and abs(inc) * (spec.n_beams - 1) <= _TWO_PI + 1e-6):
        return f"angle increment {inc!r} rad for {spec.n_beams} beams (more than 360°, or none)"
    if not (math.isfinite(spec.range_min_m) and math.isfinite(spec.range_max_m)
            and 0.0 <= spec.range_min_m < spec.range_max_m <= MAX_RANGE_M):
        return f"range interval [{spec.range_min_m!r}, {spec.range_max_m!r}] m (a scanner reaches 0 to {MAX_RANGE_M:g} m)"
    mount = spec.base_to_laser
    if not (all(math.isfinite(v) for v in (mount.x_m, mount.y_m, mount.yaw_rad))
            and math.hypot(mount.x_m, mount.y_m) <= MAX_MOUNT_M):
        return f"mount offset {mount} (a scanner sits within {MAX_MOUNT_M:g} m of the base)"
    return None


def check_spec(path: Path | str, spec: LidarSpec) -> LidarSpec:
    """``spec`` if it is plausible; else raises :class:`LogError` naming the problem."""
    problem = spec_problem(spec)
    if problem is not None:
        raise LogError(path, f"implausible scanner: {problem}")
    return spec


def ranges_problem(ranges: np.ndarray, spec: LidarSpec) -> str | None:
    """Why a scan's readings cannot be its scanner's (None: they can; any value outside the range interval is a
    "no return", REP 117)."""
    if ranges.shape != (spec.n_beams,):
        return "different beam count"
    return None


def pose_problem(pose: Pose2D) -> str | None:
    """Why an odometry pose is impossible (None: it is possible)."""
    x, y, a = pose.x_m, pose.y_m, pose.yaw_rad
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(a)):
        return "odometry not finite"
    if abs(x) > MAX_COORD_M or abs(y) > MAX_COORD_M or abs(a) > 1e6:
        return "odometry out of bounds"
    return None


def step_possible(stamp_a: int, a: Pose2D, stamp_b: int, b: Pose2D) -> bool:
    """Whether a robot can move from pose ``a`` to ``b`` in the time between the two stamps (module docstring)."""
    dt = abs(stamp_b - stamp_a) / 1e9
    if math.hypot(b.x_m - a.x_m, b.y_m - a.y_m) > MAX_SPEED_M_S * dt + STEP_SLACK_M:
        return False
    turn = MAX_TURN_RAD_S * dt + TURN_SLACK_RAD
    if turn >= math.pi:
        return True
    da = (b.yaw_rad - a.yaw_rad + math.pi) % _TWO_PI - math.pi
    return abs(da) <= turn


class _Anchor:
    """The rigid correction applied to odometry after re-anchorings (identity: poses pass unchanged)."""

    def __init__(self) -> None:
        self.t: np.ndarray | None = None

    def apply(self, p: Pose2D) -> Pose2D:
        if self.t is None:
            return p
        q = compose(self.t, p.as_array())
        return Pose2D(float(q[0]), float(q[1]), float((q[2] + math.pi) % _TWO_PI - math.pi))

    def reanchor(self, at: Pose2D, raw: Pose2D) -> None:
        """From now on ``raw`` maps to ``at``."""
        self.t = compose(at.as_array(), inverse(raw.as_array()))


def plausible_frames(path: Path | str, frames: Iterable[Frame], skipped: Counter[str] | None = None) -> Generator[Frame, None, None]:
    """The frames that pass the rules of the module docstring, in order.

    ``skipped``: counts of scans the reader itself skipped (filled while ``frames`` is consumed); they go into
    the same single warning.  Raises :class:`LogError` when frames came but none was usable.
    """
    counts: Counter[str] = skipped if skipped is not None else Counter()
    checked_specs: set[int] = set()
    buf: deque[Frame] = deque()
    anchor = _Anchor()
    last: Frame | None = None  # the last frame passed on (odometry already corrected)
    passed = 0

    def per_frame(f: Frame) -> str | None:
        if id(f.scan.spec) not in checked_specs:
            check_spec(path, f.scan.spec)
            checked_specs.add(id(f.scan.spec))
        if not 0 <= f.stamp_ns < MAX_STAMP_NS:
            return "stamp out of bounds"
        return ranges_problem(f.scan.ranges_m, f.scan.spec) or pose_problem(f.odom)

    def decide(f: Frame, rest: deque[Frame]) -> tuple[Frame | None, str | None]:
        """The frame to pass on (None: dropped) and what happened to it."""
        odom = anchor.apply(f.odom)
        if last is not None and f.stamp_ns < last.stamp_ns:
            return None, "stamp went backwards"
        if rest and rest[0].stamp_ns < f.stamp_ns:  # rare: only then count the scans after it that come earlier
            lo = last.stamp_ns if last is not None else -1
            earlier = sum(lo <= g.stamp_ns < f.stamp_ns for g in rest)
            if 2 * earlier > len(rest):
                return None, "stamp out of order"
        if last is not None and not f.odom_known:  # the reader says its motion is unknown: none is carried
            if odom == last.odom:
                return _with_odom(f, odom), None
            anchor.reanchor(last.odom, f.odom)
            return _with_odom(f, last.odom, known=False), None
        if last is None:
            # the first frame: trusted unless the frames after it agree with each other but not with it
            if len(rest) >= 2 and not _reachable(f.stamp_ns, odom, rest[0], anchor) and _chain(rest, anchor):
                return None, "odometry a robot cannot reach"
            return _with_odom(f, odom), None
        if step_possible(last.stamp_ns, last.odom, f.stamp_ns, odom):
            return _with_odom(f, odom), None
        if any(_reachable(last.stamp_ns, last.odom, g, anchor) for g in rest):
            return None, "odometry a robot cannot reach"
        if rest and _chain([f, *rest], anchor):
            anchor.reanchor(last.odom, f.odom)
            return _with_odom(f, last.odom, known=False), "reanchored"  # the motion across the jump is unknown
        return None, "odometry a robot cannot reach"

    def release(f: Frame, rest: deque[Frame]) -> Frame | None:
        nonlocal last, passed
        out, what = decide(f, rest)
        if what is not None:
            counts[what] += 1
        if out is None:
            if not f.odom_known and rest:  # its unknown motion is part of the next frame's
                rest[0] = _with_odom(rest[0], rest[0].odom, known=False)
            return None
        last = out
        passed += 1
        return out

    unknown_before = False  # a frame dropped on arrival had unknown motion: so has the next one

    for f in frames:
        problem = per_frame(f)
        if problem is not None:
            counts[problem] += 1
            unknown_before |= not f.odom_known
            continue
        if unknown_before:
            f, unknown_before = _with_odom(f, f.odom, known=False), False
        buf.append(f)
        if len(buf) > LOOKAHEAD:
            head = buf.popleft()
            out = release(head, buf)
            if out is not None:
                yield out
    while buf:
        head = buf.popleft()
        out = release(head, buf)
        if out is not None:
            yield out
    reanchored = counts.pop("reanchored", 0)
    dropped = sum(counts.values())
    if passed == 0 and dropped:
        raise LogError(path, "no usable scans: " + _summary(counts))
    parts = []
    if dropped:
        parts.append("skipped scans: " + _summary(counts))
    if reanchored:
        parts.append(f"odometry re-anchored after {reanchored} jump(s) a robot cannot make (read as unknown motion)")
    if parts:
        warn_skipped(path, "; ".join(parts))


def without_odometry(frames: Iterable[Frame]) -> Iterator[Frame]:
    """The frames as a log without odometry gives them: every motion unknown, every pose the origin."""
    origin = Pose2D()
    for f in frames:
        yield Frame(f.stamp_ns, f.scan, origin, False)


def _summary(counts: Counter[str]) -> str:
    return ", ".join(f"{n} ({why})" for why, n in counts.items() if n)


def _with_odom(f: Frame, odom: Pose2D, known: bool = True) -> Frame:
    known = known and f.odom_known
    return f if odom is f.odom and known == f.odom_known else Frame(f.stamp_ns, f.scan, odom, known)


def _reachable(stamp: int, pose: Pose2D, g: Frame, anchor: _Anchor) -> bool:
    return step_possible(stamp, pose, g.stamp_ns, anchor.apply(g.odom))


def _chain(frames: Iterable[Frame], anchor: _Anchor) -> bool:
    """Every step along ``frames`` is possible (their own odometry, before any new re-anchoring)."""
    return all(step_possible(a.stamp_ns, a.odom, b.stamp_ns, b.odom) for a, b in pairwise(frames))
