"""What a CARMEN log's laser lines give, kept compact while the log is read line by line: per-scan fields
(:class:`ScanTable`), the readings' statistics that find the scanner's range limit (:class:`RangeStats`), and the
odometry each scan gets (logged on the line, rebuilt from a Radish corrected log's re-anchored ``ODOM`` stream, or
interpolated in the ``ODOM`` stream).  Nothing here holds a scan's readings; :mod:`mcnkit.io.carmen` streams them.
"""

from __future__ import annotations

import math
from array import array
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative
from mcnkit.io.errors import LogError
from mcnkit.io.plausible import MAX_RANGE_M, STEP_SLACK_M, step_possible
from mcnkit.types import Pose2D

__all__ = ["OdomStream", "RangeStats", "ScanTable", "impossible_steps", "is_corrected_variant",
           "odometry_from_stream", "rebuild_raw_odometry", "untimed_step_limit_m"]

_NO_STAMP = -(2**63)
_MAX_DISTINCT = 1 << 20  # distinct high readings kept exactly (real logs hold a few thousand)


@dataclass
class ScanTable:
    """The laser lines of one keyword that parse, in log order: stamp, logged poses, geometry, the index of the
    last ``ODOM`` line before each (and of the first after it), and the line number."""

    stamps: array[int] = field(default_factory=lambda: array("q"))
    poses: array[float] = field(default_factory=lambda: array("d"))  # x y theta per scan; NaN: none on the line
    odoms: array[float] = field(default_factory=lambda: array("d"))
    geometry: list[tuple[int, tuple[float, float, float]]] = field(default_factory=list)  # (beams, geometry) runs
    geometry_runs: array[int] = field(default_factory=lambda: array("q"))  # first scan of each run
    odom_index: array[int] = field(default_factory=lambda: array("q"))
    first_odom_after: array[int] = field(default_factory=lambda: array("q"))
    lines: array[int] = field(default_factory=lambda: array("q"))

    def __len__(self) -> int:
        return len(self.lines)

    def add(self, stamp: int | None, pose: tuple[float, float, float] | None,
            odom: tuple[float, float, float] | None, beams: int, geometry: tuple[float, float, float],
            odom_index: int, line: int) -> None:
        """Appends one scan line's fields."""
        self.stamps.append(_NO_STAMP if stamp is None else stamp)
        self.poses.extend(pose if pose is not None else (math.nan,) * 3)
        self.odoms.extend(odom if odom is not None else (math.nan,) * 3)
        if not self.geometry or self.geometry[-1] != (beams, geometry):
            self.geometry.append((beams, geometry))
            self.geometry_runs.append(len(self.lines))
        self.odom_index.append(odom_index)
        self.first_odom_after.append(-1)
        self.lines.append(line)

    def _runs(self) -> list[tuple[tuple[int, tuple[float, float, float]], int, int]]:
        ends = [*self.geometry_runs[1:], len(self)]
        return list(zip(self.geometry, self.geometry_runs, ends, strict=True))

    def group_counts(self) -> Counter[tuple[int, tuple[float, float, float]]]:
        """How many scans have each (beams, geometry), in order of first appearance."""
        counts: Counter[tuple[int, tuple[float, float, float]]] = Counter()
        for g, a, b in self._runs():
            counts[g] += b - a
        return counts

    def rows_of(self, group: tuple[int, tuple[float, float, float]]) -> NDArray[np.intp]:
        """The scans of one (beams, geometry), in log order."""
        return np.concatenate([np.arange(a, b) for g, a, b in self._runs() if g == group] or [np.zeros(0, np.intp)])

    def stamp_list(self, rows: NDArray[np.intp]) -> list[int | None]:
        """The stamps of ``rows`` (None: the line has none)."""
        s = np.frombuffer(self.stamps, np.int64)[rows]
        return [None if v == _NO_STAMP else int(v) for v in s.tolist()]

    def array3(self, values: array[float], rows: NDArray[np.intp]) -> NDArray[np.float64]:
        """``poses`` or ``odoms`` of ``rows`` as (len(rows), 3)."""
        return np.frombuffer(values, np.float64).reshape(-1, 3)[rows].copy()

    def ints(self, values: array[int], rows: NDArray[np.intp]) -> NDArray[np.int64]:
        """An integer column of ``rows``."""
        return np.frombuffer(values, np.int64)[rows].copy()


@dataclass
class OdomStream:
    """The ``ODOM`` lines: pose and stamp (-1: none) of each, in log order."""

    poses: array[float] = field(default_factory=lambda: array("d"))
    stamps: array[int] = field(default_factory=lambda: array("q"))

    def __len__(self) -> int:
        return len(self.stamps)

    def add(self, pose: tuple[float, float, float], stamp: int | None) -> None:
        """Appends one ``ODOM`` line."""
        self.poses.extend(pose)
        self.stamps.append(-1 if stamp is None else stamp)

    def pose_array(self) -> NDArray[np.float64]:
        """(n, 3) poses."""
        return np.frombuffer(self.poses, np.float64).reshape(-1, 3)

    def stamp_array(self) -> NDArray[np.int64]:
        """(n,) stamps."""
        return np.frombuffer(self.stamps, np.int64)


class RangeStats:
    """Statistics of one scanner's readings fed scan by scan, from which :meth:`range_max` finds its range limit as
    if all readings were at hand: the count of readings in ``(0, MAX_RANGE_M]``, the largest, and the count of
    each distinct reading within the top 10 % (the only ones that can be "no return" sentinels)."""

    def __init__(self) -> None:
        self.n = 0
        self.top: float | None = None
        self.nonfinite = 0
        self.rows_nonfinite = 0
        self._vals = np.zeros(0, np.float32)
        self._counts = np.zeros(0, np.int64)
        self._pending: list[NDArray[np.float32]] = []
        self._pending_n = 0

    def add(self, r: NDArray[np.float32]) -> None:
        """One scan's readings."""
        finite = np.isfinite(r)
        if not finite.all():
            self.nonfinite += int((~finite).sum())
            self.rows_nonfinite += 1
        v = r[finite & (r > 0) & (r <= MAX_RANGE_M)]  # farther: no scanner's reading
        if len(v) == 0:
            return
        self.n += len(v)
        m = float(v.max())
        self.top = m if self.top is None else max(self.top, m)
        high = v[v >= 0.9 * self.top]
        self._pending.append(high)
        self._pending_n += len(high)
        if self._pending_n > _MAX_DISTINCT:
            self._compact()

    def _compact(self) -> None:
        if self.top is None:
            return
        vals = np.concatenate([self._vals, *self._pending])
        counts = np.concatenate([self._counts, np.ones(self._pending_n, np.int64)])
        keep = vals >= 0.9 * self.top
        vals, inverse = np.unique(vals[keep], return_inverse=True)
        self._counts = np.bincount(inverse, weights=counts[keep], minlength=len(vals)).astype(np.int64)
        self._vals = vals if len(vals) <= _MAX_DISTINCT else np.round(vals.astype(np.float64), 2).astype(np.float32)
        self._pending, self._pending_n = [], 0

    def range_max(self) -> float:
        """The scanner's range limit: 2 cm below the smallest "no return" sentinel, else the largest reading.

        Sentinels are single values at the top of the range that hold far more readings than a real return could
        (81.91 and 81.83 on SICK scanners in CARMEN logs, 50.00 / 51.14 / 51.15 in others, several in one log): a
        1 cm bin within the top 10 % of the readings' span holding at least 20 readings and 0.05 % of all of them.
        """
        if self.top is None:
            return 1.0
        self._compact()
        values, inverse = np.unique(np.round(self._vals.astype(np.float64), 2), return_inverse=True)
        counts = np.bincount(inverse, weights=self._counts, minlength=len(values))
        sentinels = values[counts >= max(20, 0.0005 * self.n)]
        return round(float(sentinels.min()) - 0.02 if len(sentinels) else self.top, 6)


def is_corrected_variant(poses: NDArray[np.float64] | None, first_after: NDArray[np.int64], odom: OdomStream) -> bool:
    """Radish corrected logs re-anchor ODOM at every scan's pose: the first ODOM after a scan equals it.  ``poses``:
    the poses logged on the scan lines (None: the lines carry none)."""
    has = first_after >= 0
    if poses is None or int(has.sum()) < max(3, len(poses) // 2):
        return False
    after = odom.pose_array()[first_after[has]]
    hits = np.all(np.abs(after - poses[has]) <= 1e-6 + 1e-5 * np.abs(poses[has]), axis=1)  # np.allclose per pair
    return int(hits.sum()) >= 0.9 * int(has.sum())


UNTIMED_STEP_FACTOR = 4.0
"""How many times the log's median step a step between scans whose stamps carry no time may be (at least
``STEP_SLACK_M``): such logs keep one scan per metre or per few metres, and a damaged line moves the robot tens."""


def untimed_step_limit_m(step_lengths_m: NDArray[np.float64]) -> float:
    """The longest step between two scans whose stamps carry no time that is read as a move: ``STEP_SLACK_M``, or
    ``UNTIMED_STEP_FACTOR`` times the median of the log's steps where its scans lie farther apart (Örebro keeps one
    scan per 2-3 m, and its odometry agrees with the corrected poses there within a few centimetres)."""
    moved = np.asarray(step_lengths_m, np.float64)
    moved = moved[np.isfinite(moved) & (moved > 1e-6)]
    return max(STEP_SLACK_M, UNTIMED_STEP_FACTOR * float(np.median(moved))) if len(moved) else STEP_SLACK_M


def rebuild_raw_odometry(corrected: NDArray[np.float64], odom_index: NDArray[np.int64], odom: OdomStream,
                         stamps: NDArray[np.int64], rebuilt: NDArray[np.bool_]
                         ) -> tuple[NDArray[np.float64], int, NDArray[np.bool_]]:
    """The raw odometry chain, how many increments were a move no robot makes (damaged numbers: read as unknown
    motion, so that one bad line does not move every pose after it), and per scan whether the motion since the
    scan before is known.

    It is not where the gap between two scans holds no ODOM line but the re-anchoring one (the previous scan's
    corrected pose itself) or none at all: those logs dropped the raw odometry there (Örebro, parts of Seattle),
    so the robot's motion is unknown, not zero.  Damaged increments are unknown too; an increment into or out of
    a scan whose stamp was rebuilt (``rebuilt``) is judged by its length alone (its stamps carry no time), against
    :func:`untimed_step_limit_m`."""
    poses = odom.pose_array()
    out = np.empty_like(corrected)
    out[0] = corrected[0] if np.isfinite(corrected[0]).all() else 0.0
    known = np.ones(len(corrected), dtype=bool)
    bad = 0
    # the increment into each scan from the corrected pose of the one before (zero where no ODOM line follows it)
    increments = np.zeros_like(corrected)
    linked = np.flatnonzero(odom_index[1:] >= 0)
    increments[linked + 1] = relative(corrected[linked], poses[odom_index[linked + 1]])
    limit_m = untimed_step_limit_m(np.hypot(increments[linked + 1, 0], increments[linked + 1, 1]))
    for k in range(len(corrected) - 1):
        j = int(odom_index[k + 1])
        increment = increments[k + 1]
        if j <= odom_index[k] or (j == odom_index[k] + 1 and bool(np.all(np.abs(increment) < 1e-6))):
            known[k + 1] = False  # no ODOM line between them but the re-anchoring one: the motion is unknown
            increment = np.zeros(3)
        elif not (np.isfinite(increment).all() and _increment_possible(increment, k, stamps, rebuilt, limit_m)):
            bad += 1
            known[k + 1] = False
            increment = np.zeros(3)
        out[k + 1] = compose(out[k], increment)
    return out, bad, known


def _increment_possible(increment: NDArray[np.float64], k: int, stamps: NDArray[np.int64], rebuilt: NDArray[np.bool_],
                        limit_m: float) -> bool:
    """Whether a robot can make the odometry ``increment`` between scans ``k`` and ``k + 1``: by its speed where both
    stamps carry time, else (a rebuilt stamp) by its length alone, any turn in place fitting between them."""
    if rebuilt[k] or rebuilt[k + 1]:
        return bool(np.hypot(increment[0], increment[1]) <= limit_m)
    return step_possible(int(stamps[k]), Pose2D(), int(stamps[k + 1]), Pose2D.from_array(increment))


def impossible_steps(odom: NDArray[np.float64], rebuilt: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per scan: the odometry step from the scan before is one no robot makes although one of the two stamps was
    rebuilt (so they carry no time to judge a speed by): longer than :func:`untimed_step_limit_m`.  A turn is not judged:
    without time a robot may turn in place by any angle between two scans (the corrected Radish logs keep one scan
    per metre or per turn, 80° apart where the robot turned at a corridor's end).  Steps between stamps that carry
    time are judged by :mod:`mcnkit.io.plausible`."""
    out = np.zeros(len(odom), dtype=bool)
    if len(odom) < 2:
        return out
    step = np.hypot(np.diff(odom[:, 0]), np.diff(odom[:, 1]))
    judged = rebuilt[1:] | rebuilt[:-1]
    with np.errstate(invalid="ignore"):
        out[1:] = judged & ~(step <= untimed_step_limit_m(step))
    return out


def odometry_from_stream(path: Path, stamps: NDArray[np.int64], odom_index: NDArray[np.int64], odom: OdomStream,
                         odom_stamps: NDArray[np.int64] | None) -> NDArray[np.float64]:
    """Odometry at scans that carry none (RAWLASER): interpolated at the scan stamps, else the last ODOM before."""
    poses = odom.pose_array()
    if len(poses) == 0:
        raise LogError(path, "no ODOM lines to give the RAWLASER scans their odometry")
    if odom_stamps is not None:
        unwrapped = poses.copy()
        unwrapped[:, 2] = np.unwrap(poses[:, 2])
        return np.stack([np.interp(stamps, odom_stamps, unwrapped[:, i]) for i in range(3)], axis=1)
    return poses[np.maximum(odom_index, 0)].copy()
