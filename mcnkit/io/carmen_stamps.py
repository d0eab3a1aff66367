"""Scan stamps of text logs: exact nanoseconds from decimal text, and stamps rebuilt when a log's carry no time.

:func:`repair_stamps` returns strictly rising stamps for scans in log order and says what was wrong with the given
ones (None: nothing).  The rules (also in :mod:`mcnkit.io.carmen`):

* stamps that only tie or step back a little (clock jitter, or stamps printed with six significant digits such as
  ``1.13486e+09``, i.e. ten-second ticks) keep their time: each run of equal (or earlier) stamps is spread evenly
  up to the next later stamp;
* stamps that carry no time at all (all equal, all zero, negative, the 32-bit sentinel ``4.29497e+09``, not
  numbers, or going back more often than forward) are replaced: by ``fallback_ns`` (the stamp of the ``ODOM`` line
  each scan follows) when those rise, else at a nominal ``period_s`` per scan;
* a few stamps without time among good ones (damaged digits, a missing field) each take the time of the scan
  before them, and are then spread like any other tie.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["SENTINEL_S", "repair_stamps", "stamp_ns"]

SENTINEL_S = 4.29e9  # 2^32 - 1 printed as seconds: an unset 32-bit stamp


def stamp_ns(text: str) -> int | None:
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
    valid = (raw > 0) & (raw < int(SENTINEL_S * 1e9))
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
    if (raw >= int(SENTINEL_S * 1e9)).any():
        problems.append(f"{int(np.count_nonzero(raw >= int(SENTINEL_S * 1e9)))} at the 32-bit sentinel 4.29497e+09")
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
    if n_sentinel := int(np.count_nonzero(raw >= int(SENTINEL_S * 1e9))):
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

