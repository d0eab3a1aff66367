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

import gzip
import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative, wrap_angle
from mcnkit.io.base import LogReader, TopicInfo
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.io.plausible import MAX_RANGE_M, check_spec, step_possible
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan, Trajectory

__all__ = ["CarmenLog", "CarmenRecord", "is_carmen", "repair_stamps"]

_FRONT = ("FLASER", "ROBOTLASER1", "RAWLASER1")
_REAR = ("RLASER", "ROBOTLASER2", "RAWLASER2", "RAWLASER3", "RAWLASER4")
_SCAN_KEYWORDS = (*_FRONT, *_REAR, "Laser")
_KEYWORDS = (*_SCAN_KEYWORDS, "ODOM", "Odometry", "PARAM", "NEFF", "SYNC", "TRUEPOS", "GPSNMEA", "BASE", "SONAR")
_SENTINEL_S = 4.29e9  # 2^32 - 1 printed as seconds: an unset 32-bit stamp


def _open_text(path: Path) -> Iterator[str]:
    opener = gzip.open if path.read_bytes()[:2] == b"\x1f\x8b" else open
    try:
        with opener(path, "rt", encoding="ascii", errors="replace") as f:
            yield from f
    except (OSError, EOFError) as err:  # truncated gzip stream
        warn_skipped(path, f"the compressed stream ends early ({err}); read what came before")


def is_carmen(path: Path) -> bool:
    """True when ``path`` is a text log whose lines start with CARMEN or DP-SLAM keywords (the first of its first
    200 non-comment lines that is not a header line decides)."""
    try:
        for n, line in enumerate(_open_text(path)):
            if n > 200:
                return False
            word = line.split(maxsplit=1)[0] if line.strip() else ""
            if not word or word.startswith("#"):
                continue
            if word in _KEYWORDS:
                return True
            if not word.isupper():  # a CARMEN header is a keyword in capitals: anything else is not this format
                return False
    except (OSError, UnicodeDecodeError, IndexError):
        return False
    return False


def _stamp_ns(text: str) -> int | None:
    """Nanoseconds from a decimal seconds string, exact for plain decimals (``1134864629.895182``); exponent
    forms (``1.13486e+09``) go through float.  None when the text is not a finite number."""
    t = text.strip()
    if not t or t.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        return None
    if "e" in t.lower():
        try:
            v = float(t)
        except ValueError:
            return None
        return round(v * 1e9) if math.isfinite(v) and abs(v) < 9e9 else None
    sign = -1 if t.startswith("-") else 1
    whole, _, frac = t.lstrip("+-").partition(".")
    if not (whole or frac) or not (whole.isdigit() or whole == "") or not (frac.isdigit() or frac == ""):
        return None
    return sign * (int(whole or 0) * 1_000_000_000 + int((frac + "000000000")[:9] or 0))


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


def _line_stamp(tok: list[str]) -> int | None:
    """The IPC stamp of a line ending in ``ipc_timestamp host logger_timestamp``, else None."""
    if len(tok) < 4 or _stamp_ns(tok[-2]) is not None:
        return None
    ipc, logger = _stamp_ns(tok[-3]), _stamp_ns(tok[-1])
    return ipc if ipc is not None and logger is not None else None


@dataclass
class _Scan:
    stamp_ns: int | None
    ranges: NDArray[np.float32]
    pose: tuple[float, float, float] | None  # the laser/corrected pose logged on the line
    odom: tuple[float, float, float] | None  # the robot's odometry pose logged on the line
    geometry: tuple[float, float, float]  # angle_min, increment, max range (inf: unknown)
    odom_index: int  # index of the last ODOM line before this scan, -1 if none


@dataclass
class _Parsed:
    scans: dict[str, list[_Scan]] = field(default_factory=dict)
    odom: list[tuple[float, float, float]] = field(default_factory=list)
    odom_stamps: list[int | None] = field(default_factory=list)
    first_odom_after_scan: dict[tuple[str, int], int] = field(default_factory=dict)
    dpslam_odom: tuple[float, float, float] | None = None
    skipped: Counter[str] = field(default_factory=Counter)
    first_skipped: dict[str, int] = field(default_factory=dict)


def _flaser_geometry(n: int) -> tuple[float, float]:
    step_deg = 180.0 / (n - 1) if n in (181, 361, 721) else 180.0 / n
    return math.radians(-90.0), math.radians(step_deg)


def _pose(tokens: list[str]) -> tuple[float, float, float]:
    x, y, t = (float(v) for v in tokens[:3])
    return x, y, t


def _parse_line(key: str, tok: list[str], out: _Parsed) -> _Scan | None:
    """The scan of a laser line (None for other lines); raises ValueError/IndexError when it cannot be parsed."""
    if key in ("FLASER", "RLASER"):
        n = int(tok[1])
        r = _floats(tok[2 : 2 + n])
        rest = tok[2 + n :]
        if n <= 0 or len(r) != n or len(rest) < 3:
            raise ValueError("short line")
        pose = _pose(rest[0:3])
        odom = _pose(rest[3:6]) if len(rest) >= 6 else pose
        stamp = _stamp_ns(rest[6]) if len(rest) >= 7 else None
        amin, inc = _flaser_geometry(n)
        return _Scan(stamp, r.astype(np.float32), pose, odom, (amin, inc, math.inf), len(out.odom) - 1)
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
            stamp = _stamp_ns(rest[11]) if len(rest) >= 12 else None
            return _Scan(stamp, r.astype(np.float32), _pose(rest[0:3]), _pose(rest[3:6]), geometry, len(out.odom) - 1)
        stamp = _stamp_ns(rest[0]) if len(rest) >= 1 else None
        return _Scan(stamp, r.astype(np.float32), None, None, geometry, len(out.odom) - 1)
    if key == "Laser":
        n = int(tok[1])
        r = _floats(tok[2 : 2 + n])
        if n <= 1 or len(r) != n or out.dpslam_odom is None:
            raise ValueError("short line or no Odometry line before it")
        odom = out.dpslam_odom
        return _Scan(None, r.astype(np.float32), odom, odom, (math.radians(-90.0), math.radians(180.0 / (n - 1)),
                                                             math.inf), -1)
    return None


def _parse(path: Path) -> _Parsed:
    out = _Parsed()
    for lineno, line in enumerate(_open_text(path), start=1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        key = tok[0]
        try:
            if key == "ODOM":
                out.odom.append(_pose(tok[1:4]))
                out.odom_stamps.append(_stamp_ns(tok[7]) if len(tok) > 7 else None)
                for k, scans in out.scans.items():
                    slot = (k, len(scans) - 1)
                    if scans and slot not in out.first_odom_after_scan:
                        out.first_odom_after_scan[slot] = len(out.odom) - 1
            elif key == "Odometry":
                out.dpslam_odom = _pose(tok[1:4])
            elif key in _SCAN_KEYWORDS:
                scan = _parse_line(key, tok, out)
                if scan is not None:
                    out.scans.setdefault(key, []).append(scan)
        except (ValueError, IndexError, OverflowError):
            out.skipped[key] += 1
            out.first_skipped.setdefault(key, lineno)
    return out


def _choose_source(p: _Parsed) -> str | None:
    """The laser the frames come from: the front one the log has most lines of, else the rear one, else DP-SLAM's."""
    for group in (_FRONT, _REAR, ("Laser",)):
        counts = {k: len(p.scans.get(k, [])) + p.skipped.get(k, 0) for k in group}
        best = max(counts, key=lambda k: counts[k])
        if counts[best] > 0:
            return best
    return None


def repair_stamps(stamps_ns: list[int | None], fallback_ns: NDArray[np.int64] | None,
                  period_s: float) -> tuple[NDArray[np.int64], str | None]:
    """Strictly rising stamps (K,) for scans in log order, and what was wrong with the given ones (None: nothing).

    ``fallback_ns``: stamps to use when the given ones carry no time (the ODOM line each scan follows), or None.
    See the module docstring for the rules.
    """
    k = len(stamps_ns)
    raw = np.array([s if s is not None else -1 for s in stamps_ns], dtype=np.int64)
    if k == 0:
        return raw, None
    missing = sum(s is None for s in stamps_ns)
    valid = (raw > 0) & (raw < int(_SENTINEL_S * 1e9))
    if valid.all() and (k == 1 or (np.diff(raw) > 0).all()):
        return raw, None
    n_bad = k - int(valid.sum())
    if 0 < n_bad <= max(1, k // 20) and valid.sum() >= 2:
        # a few stamps without time among good ones (damaged digits, a missing field): each takes the time of the
        # scan before it (the first valid one's, at the start), so it is a tie spread like any other
        filled = np.where(valid, raw, -1)
        filled[: int(np.argmax(valid))] = raw[valid][0]
        for i in np.flatnonzero(filled < 0):
            filled[i] = filled[i - 1]
        absent = np.array([st is None for st in stamps_ns])
        return _repaired_few(raw, filled, absent, fallback_ns, period_s)
    steps = np.diff(raw[valid]) if valid.sum() > 1 else np.zeros(0, np.int64)
    problems = []
    if missing:
        problems.append("no stamp" if missing == k else f"{missing} without a stamp")
    if (raw == 0).all():
        problems.append("all zero")
    elif (raw < 0).any() and not missing:
        problems.append(f"{int(np.count_nonzero(raw < 0))} negative")
    if (raw >= int(_SENTINEL_S * 1e9)).any():
        problems.append(f"{int(np.count_nonzero(raw >= int(_SENTINEL_S * 1e9)))} at the 32-bit sentinel 4.29497e+09")
    n_distinct = len(np.unique(raw[valid]))
    backwards = int(np.count_nonzero(steps < 0))
    # Time that mostly moves forward with a few ties or slips (jitter) is kept; time that goes back about as much as
    # forward, or whose ticks are so coarse that most scans share one (six significant digits), is not.
    usable = valid.all() and n_distinct >= max(2, k // 2) and int(steps[steps > 0].sum()) > 2 * int(-steps[steps < 0].sum())
    if valid.any() and n_distinct == 1 and k > 1:
        problems.append(f"all equal ({raw[valid][0] / 1e9:.9g})")
    elif valid.all() and 1 < n_distinct < k // 2:
        problems.append(f"only {n_distinct} distinct values for {k} scans (printed with too few digits?)")
    if usable:
        ties = int(np.count_nonzero(steps == 0))
        if backwards:
            problems.append(f"{backwards} earlier than the scan before")
        if ties:
            problems.append(f"{ties} equal to the scan before ({n_distinct} distinct values: too few digits?)")
        return _spread(raw), (f"scan stamps: {', '.join(problems)}; kept in log order, each run of equal or earlier "
                              "stamps spread evenly up to the next later one")
    if backwards and valid.all():
        problems.append(f"{backwards} going backwards")
    what = ", ".join(problems) or "unusable"
    if fallback_ns is not None and len(fallback_ns) == k and (fallback_ns > 0).all() and len(np.unique(fallback_ns)) > 1 \
            and (np.diff(fallback_ns) >= 0).all():
        return _spread(fallback_ns), f"scan stamps: {what}; stamped from the ODOM lines they follow"
    t0 = int(raw[valid][0]) if valid.any() else 0
    out = t0 + np.round(np.arange(k) * period_s * 1e9).astype(np.int64)
    return out, f"scan stamps: {what}; stamped in log order every {period_s:g} s"


def _repaired_few(raw: NDArray[np.int64], filled: NDArray[np.int64], absent: NDArray[np.bool_],
                  fallback_ns: NDArray[np.int64] | None, period_s: float) -> tuple[NDArray[np.int64], str | None]:
    """:func:`repair_stamps` for a log whose stamps are good but for a few (``absent``: no stamp field): those are
    named in the warning, and the filled-in stamps go through the usual rules (ties and slips spread)."""
    what = []
    if n_absent := int(absent.sum()):
        what.append(f"{n_absent} without a stamp")
    if n_low := int(np.count_nonzero((raw <= 0) & ~absent)):
        what.append(f"{n_low} zero or negative")
    if n_sentinel := int(np.count_nonzero(raw >= int(_SENTINEL_S * 1e9))):
        what.append(f"{n_sentinel} at the 32-bit sentinel 4.29497e+09")
    stamps, problem = repair_stamps([int(v) for v in filled], fallback_ns, period_s)
    named = f"scan stamps: {', '.join(what)} (each given the time of the scan before)"
    return stamps, named + ("; " + problem.removeprefix("scan stamps: ") if problem else "")


def _spread(stamps: NDArray[np.int64]) -> NDArray[np.int64]:
    """Running maximum, then each run of equal values spread evenly up to the next larger value (the last run by
    the median step): strictly rising, as close to the given times as log order allows."""
    t = stamps.astype(np.int64)
    if len(t) >= 3:
        # one stamp far ahead of the next while the one before is not (damaged digits) takes its predecessor's time
        # instead of pulling every later stamp up to it
        step = max(int(np.median(np.abs(np.diff(t)))), 1)
        ahead = t[1:-1] - t[2:]
        spike = np.flatnonzero((ahead > max(10 * step, 1_000_000_000)) & (t[:-2] <= t[2:])) + 1
        t = t.copy()
        t[spike] = t[spike - 1]
    m = np.maximum.accumulate(t)
    k = len(m)
    starts = np.flatnonzero(np.r_[True, m[1:] != m[:-1]])
    ends = np.r_[starts[1:], k]
    distinct = m[starts]
    step = int(np.median(np.diff(distinct))) if len(distinct) > 1 else 1_000_000_000
    out = m.copy()
    for s, e, v in zip(starts, ends, distinct, strict=True):
        nxt = int(m[e]) if e < k else int(v) + step * (e - s)
        out[s:e] = v + (np.arange(e - s) * (nxt - v)) // (e - s)
    return out


def _is_corrected_variant(scans: list[_Scan], p: _Parsed, key: str) -> bool:
    """Radish corrected logs re-anchor ODOM at every scan's pose: the first ODOM after a scan equals it."""
    pairs = [(k, j) for (name, k), j in p.first_odom_after_scan.items() if name == key]
    if len(pairs) < max(3, len(scans) // 2) or any(s.pose is None for s in scans):
        return False
    hits = sum(np.allclose(p.odom[j], scans[k].pose, atol=1e-6) for k, j in pairs)  # type: ignore[arg-type]
    return hits >= 0.9 * len(pairs)


def _rebuild_raw_odometry(scans: list[_Scan], p: _Parsed,
                          stamps: NDArray[np.int64]) -> tuple[NDArray[np.float64], int, NDArray[np.bool_]]:
    """The raw odometry chain, how many increments were a move no robot makes (damaged numbers: read as unknown
    motion, so that one bad line does not move every pose after it), and per scan whether the motion since the
    scan before is known.

    It is not where the gap between two scans holds no ODOM line but the re-anchoring one (the previous scan's
    corrected pose itself) or none at all: those logs dropped the raw odometry there (Örebro, parts of Seattle),
    so the robot's motion is unknown, not zero.  Damaged increments are unknown too."""
    corrected = np.asarray([s.pose for s in scans], dtype=np.float64)
    odom = np.empty_like(corrected)
    odom[0] = corrected[0] if np.isfinite(corrected[0]).all() else 0.0
    known = np.ones(len(corrected), dtype=bool)
    bad = 0
    zero = Pose2D()
    for k in range(len(corrected) - 1):
        j = scans[k + 1].odom_index
        increment = relative(corrected[k], np.asarray(p.odom[j])) if j >= 0 else np.zeros(3)
        anchor_only = j == scans[k].odom_index + 1 and bool(np.all(np.abs(increment) < 1e-6))
        if j <= scans[k].odom_index or anchor_only:
            known[k + 1] = False
            increment = np.zeros(3)
        elif not (np.isfinite(increment).all()
                  and step_possible(int(stamps[k]), zero, int(stamps[k + 1]), Pose2D.from_array(increment))):
            bad += 1
            known[k + 1] = False
            increment = np.zeros(3)
        odom[k + 1] = compose(odom[k], increment)
    return odom, bad, known


def _odometry_from_stream(path: Path, scans: list[_Scan], stamps: NDArray[np.int64], p: _Parsed,
                          odom_stamps: NDArray[np.int64] | None) -> NDArray[np.float64]:
    """Odometry at scans that carry none (RAWLASER): interpolated at the scan stamps, else the last ODOM before."""
    poses = np.asarray(p.odom, dtype=np.float64)
    if len(poses) == 0:
        raise LogError(path, "no ODOM lines to give the RAWLASER scans their odometry")
    if odom_stamps is not None:
        unwrapped = poses.copy()
        unwrapped[:, 2] = np.unwrap(poses[:, 2])
        out = np.stack([np.interp(stamps, odom_stamps, unwrapped[:, i]) for i in range(3)], axis=1)
        return out
    idx = np.array([max(s.odom_index, 0) for s in scans])
    return poses[idx]


def _range_max(ranges: NDArray[np.float32]) -> float:
    """The scanner's range limit: 2 cm below the smallest "no return" sentinel, else the largest reading.

    Sentinels are single values at the top of the range that hold far more readings than a real return could
    (81.91 and 81.83 on SICK scanners in CARMEN logs, 50.00 / 51.14 / 51.15 in others, several in one log): a
    1 cm bin within the top 10 % of the readings' span holding at least 20 readings and 0.05 % of all of them.
    """
    allr = ranges[np.isfinite(ranges) & (ranges > 0) & (ranges <= MAX_RANGE_M)]  # farther: no scanner's reading
    if len(allr) == 0:
        return 1.0
    top = float(allr.max())
    high = allr[allr >= 0.9 * top]
    values, counts = np.unique(np.round(high.astype(np.float64), 2), return_counts=True)
    sentinels = values[counts >= max(20, 0.0005 * len(allr))]
    return round(float(sentinels.min()) - 0.02 if len(sentinels) else top, 6)


class CarmenLog(LogReader):
    """A CARMEN or DP-SLAM log held in memory (these logs are small: MIT CSAIL is 6 MB).

    Args:
        path: the log.
        period_s: seconds between scans when the log's stamps carry no time (DP-SLAM logs have none).
    """

    def __init__(self, path: Path, period_s: float = 0.2) -> None:
        self.path = path
        p = _parse(path)
        key = _choose_source(p)
        if key is None or not p.scans.get(key):
            skipped = sum(p.skipped.values())
            why = f" ({skipped} laser line(s) could not be parsed)" if skipped else ""
            raise LogError(path, f"no laser scans (FLASER, RLASER, ROBOTLASER, RAWLASER or Laser lines) in this "
                                 f"CARMEN log{why}")
        scans = p.scans[key]
        self.laser_lines = len(scans) + p.skipped.get(key, 0)
        """Laser lines of the chosen laser in the log (read or not)."""
        self.laser_keyword = key
        beams = Counter((len(s.ranges), s.geometry) for s in scans)
        n_beams, geometry = beams.most_common(1)[0][0]
        if len(beams) > 1:
            n_other = sum(c for b, c in beams.items() if b != (n_beams, geometry))
            warn_skipped(path, f"{n_other} {key} line(s) with another beam count or geometry than the {n_beams} beams "
                               "of the rest skipped")
            scans = [s for s in scans if len(s.ranges) == n_beams and s.geometry == geometry]
        if p.skipped:
            parts = ", ".join(f"{c} {k} (first at line {p.first_skipped[k]})" for k, c in p.skipped.items())
            warn_skipped(path, f"malformed line(s) skipped: {parts}")
        self.format = "dpslam" if key == "Laser" else "carmen"
        odom_stamps = np.array([s if s is not None else -1 for s in p.odom_stamps], dtype=np.int64)
        odom_ok = len(odom_stamps) > 1 and (odom_stamps > 0).all() and (np.diff(odom_stamps) > 0).all()
        fallback = None
        if odom_ok:
            fallback = np.array([odom_stamps[max(s.odom_index, 0)] + 1 for s in scans], dtype=np.int64)
        stamps, problem = repair_stamps([s.stamp_ns for s in scans], fallback, period_s)
        if problem is not None and self.format != "dpslam":
            warn_skipped(path, problem)
        self._gt: Trajectory | None = None
        self._keywords: dict[str, int] | None = None
        odom_known = np.ones(len(scans), dtype=bool)
        if self.format == "carmen" and _is_corrected_variant(scans, p, key):
            self.format = "carmen-corrected"
            odom, bad, odom_known = _rebuild_raw_odometry(scans, p, stamps)
            if bad:
                warn_skipped(path, f"{bad} odometry increment(s) a robot cannot make (damaged numbers?) read as "
                                   "unknown motion")
            if gaps := int((~odom_known).sum()) - bad:
                warn_skipped(path, f"no odometry between {gaps} of {len(scans) - 1} pairs of consecutive scans: "
                                   "read as unknown motion (searched for by scan matching)")
            self._gt = Trajectory(stamps.copy(), np.asarray([s.pose for s in scans], dtype=np.float64))
        elif scans[0].odom is None:
            odom = _odometry_from_stream(path, scans, stamps, p, odom_stamps if odom_ok and problem is None else None)
        else:
            odom = np.asarray([s.odom for s in scans], dtype=np.float64)
        odom[:, 2] = wrap_angle(odom[:, 2])  # logs hold headings outside [-pi, pi)
        self._stamps = stamps
        self._odom = odom
        self._odom_known = odom_known
        self._ranges = np.stack([s.ranges for s in scans])
        if n_bad := int((~np.isfinite(self._ranges)).sum()):  # CARMEN writes numbers: nan / inf are damage
            rows = int((~np.isfinite(self._ranges)).any(axis=1).sum())
            warn_skipped(path, f"{n_bad} range reading(s) in {rows} scan(s) are not numbers (nan / inf): read as no return")
        if self._gt is not None:
            gt_poses = self._gt.poses.copy()
            gt_poses[:, 2] = wrap_angle(gt_poses[:, 2])
            self._gt = Trajectory(self._gt.stamps_ns, gt_poses)
        amin, inc, max_range = geometry
        # The scan line's laser pose and robot pose give the mount offset of the laser on the base.
        first = scans[0]
        offset = np.zeros(3)
        if self.format == "carmen" and first.pose is not None and first.odom is not None:
            offset = np.round(relative(np.asarray(first.odom), np.asarray(first.pose)), 9)
            if not np.isfinite(offset).all() or np.hypot(offset[0], offset[1]) > 2.0:  # not a mount offset
                offset = np.zeros(3)
        offset += 0.0  # no negative zeros
        rmax = _range_max(self._ranges) if math.isinf(max_range) else max_range
        try:
            spec = LidarSpec(amin, inc, int(self._ranges.shape[1]), 0.0, rmax, Pose2D.from_array(offset))
        except ValueError as err:
            raise LogError(path, f"implausible scanner: {err}") from err
        self._spec = check_spec(path, spec)

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
        """CARMEN logs are read as one scan stream."""
        return "/scan"

    @property
    def odom_source(self) -> str:
        """Where the odometry comes from in this variant."""
        if self.format == "carmen-corrected":
            return "raw odometry rebuilt from the re-anchored ODOM stream"
        if self.format == "dpslam":
            return "Odometry lines"
        if self.laser_keyword.startswith("RAWLASER"):
            return "ODOM lines at the scan stamps"
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
        for stamp, ranges, odom, known in zip(self._stamps, self._ranges, self._odom, self._odom_known, strict=True):
            yield Frame(int(stamp), Scan(ranges, self._spec), Pose2D.from_array(odom), bool(known))

    def ground_truth(self) -> Trajectory | None:
        """The corrected trajectory of a Radish corrected log (the laser poses on its scan lines)."""
        return self._gt

    @property
    def keywords(self) -> dict[str, int]:
        """How many lines of each keyword the log holds (``#`` comments not counted), in order of first use."""
        if self._keywords is None:
            counts: Counter[str] = Counter()
            for line in _open_text(self.path):
                word = line.split(maxsplit=1)[0] if line.strip() else ""
                if word and not word.startswith("#"):
                    counts[word] += 1
            self._keywords = dict(counts)
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
            for lineno, line in enumerate(_open_text(self.path), start=1):
                tok = line.split()
                if not tok:
                    continue
                stamp = _line_stamp(tok)
                last = stamp if stamp is not None else last
                if tok[0] == topic:
                    yield last, CarmenRecord(tok[0], tuple(tok[1:]), lineno, stamp)
