"""The lines of CARMEN and DP-SLAM logs: reading them within ``MAX_LINE_BYTES`` (gzip'd or not), parsing the laser
lines of every dialect, and the first pass over a log (:func:`parse`) that :class:`~mcnkit.io.carmen.CarmenLog`
builds its frames from.  See :mod:`mcnkit.io.carmen` for the dialects and the rules."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.io.carmen_scans import OdomStream, RangeStats, ScanTable
from mcnkit.io.carmen_stamps import stamp_ns
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.io.limits import MAX_LINE_BYTES, mib
from mcnkit.io.streams import open_decompressed, text_lines

__all__ = ["FRONT", "KEYWORDS", "REAR", "SCAN_KEYWORDS", "CarmenRecord", "LineTooLong", "Parsed", "choose_source",
           "is_carmen", "keyword", "line_stamp", "lines", "parse", "read_ranges", "stats_of"]

FRONT = ("FLASER", "ROBOTLASER1", "RAWLASER1")
REAR = ("RLASER", "ROBOTLASER2", "RAWLASER2", "RAWLASER3", "RAWLASER4")
SCAN_KEYWORDS = (*FRONT, *REAR, "Laser")
KEYWORDS = (*SCAN_KEYWORDS, "ODOM", "Odometry", "PARAM", "NEFF", "SYNC", "TRUEPOS", "GPSNMEA", "BASE", "SONAR")
_PARSED = frozenset((*SCAN_KEYWORDS, "ODOM", "Odometry"))
_MAX_GROUPS = 16  # (beams, geometry) groups of one keyword whose readings are summarised during the first pass
_CACHE_BYTES = 1 << 25  # readings kept from the first pass, so that a log of this size is parsed once


class LineTooLong(LogError):
    """A line longer than ``MAX_LINE_BYTES``; ``word``: its first word."""

    def __init__(self, path: Path, problem: str, word: str) -> None:
        super().__init__(path, problem)
        self.word = word


def keyword(line: str) -> str:
    """The first word of a line ('' for a blank one), found without splitting the whole line."""
    head = line[:64].split(maxsplit=1)
    return head[0] if head else ""


def lines(path: Path) -> Iterator[str]:
    """The lines of a text log, gzip'd or not; :class:`LogError` for a line longer than ``MAX_LINE_BYTES``."""
    with open(path, "rb") as f:
        gz = f.read(2) == b"\x1f\x8b"
    try:
        with open_decompressed(path, "gzip") if gz else open(path, "rb") as stream:
            for n, (line, whole) in enumerate(text_lines(stream, MAX_LINE_BYTES), start=1):
                if not whole:
                    raise LineTooLong(path, f"line {n} is longer than {mib(MAX_LINE_BYTES)}, which no line of a text "
                                            "robot log is", keyword(line))
                yield line
    except (OSError, EOFError) as err:  # truncated gzip stream
        warn_skipped(path, f"the compressed stream ends early ({err}); read what came before")


def is_carmen(path: Path) -> bool:
    """True when ``path`` is a text log whose lines start with CARMEN or DP-SLAM keywords (the first of its first
    200 non-comment lines that is not a header line decides).  Raises :class:`LineTooLong` when a line of such a
    keyword is longer than any line of a log, and :class:`LogError` for a compressed file that decompresses beyond
    ``MAX_RATIO``."""
    try:
        for n, line in enumerate(lines(path)):
            if n > 200:
                return False
            word = keyword(line)
            if not word or word.startswith("#"):
                continue
            if word in KEYWORDS:
                return True
            if not word.isupper():  # a CARMEN header is a keyword in capitals: anything else is not this format
                return False
    except LineTooLong as err:
        if err.word in KEYWORDS:  # a log of this format, with a line no log has
            raise
        return False
    except (OSError, UnicodeDecodeError, IndexError):
        return False
    return False


def _floats(tokens: list[str]) -> NDArray[np.float64]:
    return np.array([float(t) for t in tokens], dtype=np.float64)


@dataclass(frozen=True)
class CarmenRecord:
    """One line of a CARMEN log as written: its keyword, the words after it, where it is, and its own stamp."""

    keyword: str
    fields: tuple[str, ...]
    """The words after the keyword, as text (a ``PARAM`` line's name and value, a ``FLASER`` line's numbers...)."""
    line: int
    """1-based line number in the (decompressed) log."""
    stamp_ns: int | None
    """The line's IPC stamp (the third word from the end, before host and logger stamp), when it has one."""


def line_stamp(tok: list[str]) -> int | None:
    """The IPC stamp of a line ending in ``ipc_timestamp host logger_timestamp``, else None."""
    if len(tok) < 4 or stamp_ns(tok[-2]) is not None:
        return None
    ipc, logger = stamp_ns(tok[-3]), stamp_ns(tok[-1])
    return ipc if ipc is not None and logger is not None else None


@dataclass
class _Scan:
    stamp_ns: int | None
    ranges: NDArray[np.float32]
    pose: tuple[float, float, float] | None  # the laser/corrected pose logged on the line
    odom: tuple[float, float, float] | None  # the robot's odometry pose logged on the line
    geometry: tuple[float, float, float]  # angle_min, increment, max range (inf: unknown)


Group = tuple[int, tuple[float, float, float]]


@dataclass
class Parsed:
    tables: dict[str, ScanTable] = field(default_factory=dict)
    odom: OdomStream = field(default_factory=OdomStream)
    dpslam_odom: tuple[float, float, float] | None = None
    skipped: Counter[str] = field(default_factory=Counter)
    first_skipped: dict[str, int] = field(default_factory=dict)
    stats: dict[tuple[str, Group], RangeStats] = field(default_factory=dict)
    cache: dict[str, list[NDArray[np.float32]]] | None = field(default_factory=dict)
    cache_bytes: int = 0

    def take(self, key: str, scan: _Scan, line: int) -> None:
        """Files one parsed laser line: its fields, its readings' statistics and (while they fit) the readings."""
        table = self.tables.setdefault(key, ScanTable())
        table.add(scan.stamp_ns, scan.pose, scan.odom, len(scan.ranges), scan.geometry, len(self.odom) - 1, line)
        group = (key, (len(scan.ranges), scan.geometry))
        stats = self.stats.get(group)
        if stats is None and sum(k == key for k, _ in self.stats) < _MAX_GROUPS:
            stats = self.stats[group] = RangeStats()
        if stats is not None:
            stats.add(scan.ranges)
        if self.cache is not None:
            self.cache_bytes += scan.ranges.nbytes
            self.cache = None if self.cache_bytes > _CACHE_BYTES else self.cache
        if self.cache is not None:
            self.cache.setdefault(key, []).append(scan.ranges)


def _flaser_geometry(n: int) -> tuple[float, float]:
    step_deg = 180.0 / (n - 1) if n in (181, 361, 721) else 180.0 / n
    return math.radians(-90.0), math.radians(step_deg)


def _pose(tokens: list[str]) -> tuple[float, float, float]:
    x, y, t = (float(v) for v in tokens[:3])
    return x, y, t


def _parse_line(key: str, tok: list[str], dpslam_odom: tuple[float, float, float] | None) -> _Scan | None:
    """The scan of a laser line (None for other lines); raises ValueError/IndexError when it cannot be parsed."""
    if key in ("FLASER", "RLASER"):
        n = int(tok[1])
        r = _floats(tok[2 : 2 + n])
        rest = tok[2 + n :]
        if n <= 0 or len(r) != n or len(rest) < 3:
            raise ValueError("short line")
        pose = _pose(rest[0:3])
        odom = _pose(rest[3:6]) if len(rest) >= 6 else pose
        stamp = stamp_ns(rest[6]) if len(rest) >= 7 else None
        amin, inc = _flaser_geometry(n)
        return _Scan(stamp, r.astype(np.float32), pose, odom, (amin, inc, math.inf))
    if key.startswith(("ROBOTLASER", "RAWLASER")):
        start, _fov, res, max_range = (float(t) for t in tok[2:6])
        n = int(tok[8])
        r = _floats(tok[9 : 9 + n])
        m = int(tok[9 + n])
        rest = tok[10 + n + m :]
        if n <= 0 or len(r) != n or m < 0 or not math.isfinite(res) or res == 0 or not math.isfinite(start):
            raise ValueError("short line")
        geometry = (start, res, max_range if max_range > 0 else math.inf)
        if key.startswith("ROBOTLASER"):
            if len(rest) < 6:
                raise ValueError("short line")
            stamp = stamp_ns(rest[11]) if len(rest) >= 12 else None
            return _Scan(stamp, r.astype(np.float32), _pose(rest[0:3]), _pose(rest[3:6]), geometry)
        stamp = stamp_ns(rest[0]) if len(rest) >= 1 else None
        return _Scan(stamp, r.astype(np.float32), None, None, geometry)
    if key == "Laser":
        n = int(tok[1])
        r = _floats(tok[2 : 2 + n])
        if n <= 1 or len(r) != n or dpslam_odom is None:
            raise ValueError("short line or no Odometry line before it")
        return _Scan(None, r.astype(np.float32), dpslam_odom, dpslam_odom,
                     (math.radians(-90.0), math.radians(180.0 / (n - 1)), math.inf))
    return None


def parse(path: Path) -> Parsed:
    out = Parsed()
    for lineno, line in enumerate(lines(path), start=1):
        key = keyword(line)
        if key not in _PARSED:  # comments, other sensors (a camera image as text): not split
            continue
        tok = line.split()
        try:
            if key == "ODOM":
                out.odom.add(_pose(tok[1:4]), stamp_ns(tok[7]) if len(tok) > 7 else None)
                for table in out.tables.values():
                    if table.first_odom_after[-1] == -1:
                        table.first_odom_after[-1] = len(out.odom) - 1
            elif key == "Odometry":
                out.dpslam_odom = _pose(tok[1:4])
            elif key in SCAN_KEYWORDS:
                scan = _parse_line(key, tok, out.dpslam_odom)
                if scan is not None:
                    out.take(key, scan, lineno)
        except (ValueError, IndexError, OverflowError):
            out.skipped[key] += 1
            out.first_skipped.setdefault(key, lineno)
    return out


def stats_of(path: Path, key: str, line_numbers: NDArray[np.int64]) -> RangeStats:
    """The readings' statistics of the laser lines at ``line_numbers`` (a group the first pass did not summarise)."""
    stats = RangeStats()
    for ranges in read_ranges(path, key, line_numbers):
        stats.add(ranges)
    return stats


def read_ranges(path: Path, key: str, line_numbers: NDArray[np.int64]) -> Iterator[NDArray[np.float32]]:
    """The readings of the laser lines at ``line_numbers`` (ascending), parsed again."""
    want = line_numbers.tolist()
    i = 0
    for lineno, line in enumerate(lines(path), start=1):
        if i == len(want):
            return
        if lineno != want[i]:
            continue
        try:
            scan = _parse_line(key, line.split(), (0.0, 0.0, 0.0))
        except (ValueError, IndexError, OverflowError):
            scan = None
        if scan is None:
            raise LogError(path, f"line {lineno} changed while the log was being read")
        yield scan.ranges
        i += 1
    if i < len(want):
        raise LogError(path, "the log got shorter while it was being read")


def choose_source(p: Parsed) -> str | None:
    """The laser the frames come from: the front one the log has most lines of, else the rear one, else DP-SLAM's."""
    for group in (FRONT, REAR, ("Laser",)):
        counts = {k: len(p.tables.get(k, ())) + p.skipped.get(k, 0) for k in group}
        best = max(counts, key=lambda k: counts[k])
        if counts[best] > 0:
            return best
    return None
