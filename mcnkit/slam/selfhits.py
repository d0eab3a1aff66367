"""Returns of the robot's own body: :class:`SelfHits` tells them from the world's and drops them.

A scanner mounted among a robot's parts sees some of them: the four standoffs and the camera mount around a
TurtleBot 4's RPLIDAR, the posts of a plate added above a TurtleBot 3's, a bumper.  Those returns lie at a fixed
short range on fixed beams whatever the robot does, so a SLAM that keeps them writes them into its map wherever the
robot stands still and matches scans against them.  A return of the world changes as the robot moves, but not
every motion tells: driving along a wall, or round a corner, at a fixed clearance keeps a side beam's range as
constant as a standoff's (a planner that keeps its distance from walls does this all the time).  Turning in place
does tell: a point of the world leaves the beam as the robot turns under it, and only a wall curving round the
robot at that very range could keep it there.  It must be a quarter turn: a flat wall 0.26 m away keeps a beam that
sweeps 45° across it within 2 cm of one range, one that sweeps 90° changes by 0.11 m (by 41 % of the wall's distance
at least, more than the tolerance for any wall farther than 0.12 m, inside every robot's body).  So a beam's short returns (within ``reach_m``) are taken for the
robot's own once they have stayed at one range (within ``tolerance_m``), without a break, while the robot turned
``confirm_rad`` in place (steps whose translation is under half the arc the turn sweeps at that range: rounding a
corner at the return's distance sweeps the whole arc), or drove ``confirm_m`` (off unless asked: a wall-following
robot fools it).  From then
on that beam's returns at that range are dropped (made "no return"); its other returns are kept, so a beam on a
standoff's edge still sees the room behind it.  An own beam whose short returns leave that range
``release_after`` times has seen the world after all and is filtered no more.  Causal and per scan: a log of any
length is filtered as it streams.

Example:
    >>> hits = SelfHits(reach_m=0.3, tolerance_m=0.05)
    >>> for _ in range(17):  # a turn in place of 1.7 rad, one beam on a standoff
    ...     out = hits.filter(np.array([0.14, 2.0, 3.0], np.float32), turned_rad=0.1)
    >>> out
    array([nan,  2.,  3.], dtype=float32)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["SelfHits"]

FloatArray = NDArray[np.floating]


class SelfHits:
    """The robot's own returns, learnt beam by beam from the scans as they come (see the module docstring)."""

    def __init__(self, reach_m: float, tolerance_m: float, confirm_m: float = math.inf,
                 confirm_rad: float = math.pi / 2, release_after: int = 3) -> None:
        if reach_m < 0 or tolerance_m <= 0 or confirm_m <= 0 or confirm_rad <= 0 or release_after < 1:
            raise ValueError(f"reach_m must be >= 0; tolerance_m, confirm_m and confirm_rad > 0; release_after >= 1: "
                             f"{reach_m}, {tolerance_m}, {confirm_m}, {confirm_rad}, {release_after}")
        self.reach_m = float(reach_m)
        self.tolerance_m = float(tolerance_m)
        self.confirm_m = float(confirm_m)
        self.confirm_rad = float(confirm_rad)
        self.release_after = int(release_after)
        self._first = np.zeros(0)  # (B,) the range of the beam's current run of short returns (NaN: none)
        self._run_m = np.zeros(0)  # (B,) how far the robot drove during that run ...
        self._run_rad = np.zeros(0)  # ... and turned
        self._own = np.zeros(0, np.bool_)  # (B,) runs long enough: the robot's own body
        self._moved = np.zeros(0, np.int64)  # (B,) short returns of an own beam away from its range
        self.n_dropped = 0
        """Returns dropped so far."""

    @property
    def beams(self) -> NDArray[np.intp]:
        """The beams whose short returns are taken for the robot's own."""
        return np.flatnonzero(self._own & (self._moved < self.release_after))

    @property
    def released(self) -> NDArray[np.intp]:
        """The beams once taken for the robot's own whose short returns then moved: the world's after all."""
        return np.flatnonzero(self._own & (self._moved >= self.release_after))

    def filter(self, ranges_m: NDArray[np.floating], moved_m: float = 0.0, turned_rad: float = 0.0) -> FloatArray:
        """``ranges_m`` (B,) with the robot's own returns made "no return" (NaN); a new array of its float type.
        ``moved_m`` and ``turned_rad``: how far the robot drove and turned since the previous scan."""
        r = np.array(ranges_m, dtype=np.result_type(np.asarray(ranges_m).dtype, np.float32))
        if self.reach_m <= 0:
            return r
        n = len(r)
        if len(self._first) != n:  # the first scan (or a scanner with another beam count): start afresh
            self._first, self._run_m, self._run_rad = np.full(n, np.nan), np.zeros(n), np.zeros(n)
            self._own, self._moved = np.zeros(n, np.bool_), np.zeros(n, np.int64)
        with np.errstate(invalid="ignore"):
            returned = np.isfinite(r) & (r > 0)
            short = returned & (r < self.reach_m)
            near = short & (np.abs(r - self._first) <= self.tolerance_m)
        # a run goes on while the beam returns at its range (or not at all); anything else ends it
        running = np.isfinite(self._first) & (near | ~returned)
        self._run_m = np.where(running, self._run_m + abs(moved_m), 0.0)
        with np.errstate(invalid="ignore"):  # a turn in place for a return at this range (see the module docstring)
            in_place = abs(moved_m) < 0.5 * self._first * abs(turned_rad)
        self._run_rad = np.where(running, self._run_rad + np.where(in_place, abs(turned_rad), 0.0), 0.0)
        ended = ~running & ~self._own
        self._first[ended] = np.where(short, r, np.nan)[ended]  # a new run starts at a short return
        self._own |= running & ((self._run_m >= self.confirm_m) | (self._run_rad >= self.confirm_rad))
        self._moved += self._own & short & ~near
        drop = self._own & near & (self._moved < self.release_after)
        r[drop] = np.nan
        self.n_dropped += int(drop.sum())
        return r
