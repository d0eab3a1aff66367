"""Header stamps judged against record times: one stamp that jumped (damaged bytes) is told from a clock that runs at
a constant offset (a bag re-recorded later).

The offset ``stamp - record time`` of each message is compared with the median offset of the last 15 messages of
its stream (seeded with the first ones): within ``STAMP_TOLERANCE_S`` it is fine.  Every offset, kept or not, moves
the median, so a lasting clock change is followed.
"""

from __future__ import annotations

from collections import deque

__all__ = ["STAMP_TOLERANCE_S", "StampCheck"]

STAMP_TOLERANCE_S = 3.0
_STAMP_TOLERANCE_NS = int(STAMP_TOLERANCE_S * 1e9)


class StampCheck:
    """Whether a message's ``header stamp - record time`` is within ``STAMP_TOLERANCE_S`` of its stream's median
    (of the last 15 offsets, refreshed every 8 messages)."""

    def __init__(self) -> None:
        self.offsets: deque[int] = deque(maxlen=15)
        self._median: int | None = None
        self._since = 0

    def seed(self, offset: int) -> bool:
        """Adds a first offset; True once the seed is complete."""
        self.offsets.append(offset)
        self._median = None
        return len(self.offsets) == self.offsets.maxlen

    def ok(self, offset: int) -> bool:
        """Judges one offset (every offset, kept or not, moves the median: a lasting clock change is followed)."""
        self.offsets.append(offset)
        self._since += 1
        if self._median is None or self._since >= 8:
            ordered = sorted(self.offsets)
            self._median, self._since = ordered[len(ordered) // 2], 0
        if abs(offset - self._median) <= _STAMP_TOLERANCE_NS:
            return True
        ordered = sorted(self.offsets)  # the median may just have moved (a lasting change)
        self._median, self._since = ordered[len(ordered) // 2], 0
        return abs(offset - self._median) <= _STAMP_TOLERANCE_NS
